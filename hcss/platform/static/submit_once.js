// A study form is sent once: a double click on Continue would send it twice,
// and the second copy, refused by the server as already submitted, showed the
// participant an alarming "this page has already been submitted". The clicked
// button keeps its name and value (it is not disabled, the form just ignores
// further submits); the server still refuses any repeat that gets through.
// Loaded in <head> and listening on the document (capture phase), so it guards
// every form from the moment the page starts to render: a listener added per
// form at the end of <body> left a window in which a quick double click got
// through (the page was usable before that script had run).
(() => {
  "use strict";
  document.addEventListener(
    "submit",
    (event) => {
      const form = event.target;
      if (!(form instanceof HTMLFormElement) || form.method !== "post" || !form.closest("main.study")) return;
      if (form.dataset.sent === "yes") {
        event.preventDefault();
        return;
      }
      form.dataset.sent = "yes";
    },
    true,
  );
  // Back from the browser's cache (the back button): the form may be sent again.
  window.addEventListener("pageshow", (event) => {
    if (event.persisted) for (const form of document.querySelectorAll("form[data-sent]")) delete form.dataset.sent;
  });
})();
