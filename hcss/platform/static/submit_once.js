// A study form is sent once: a double click on Continue would send it twice,
// and the second copy, refused by the server as already submitted, showed the
// participant an alarming "this page has already been submitted". The clicked
// button keeps its name and value (it is not disabled, the form just ignores
// further submits); the server still refuses any repeat that gets through.
(() => {
  "use strict";
  for (const form of document.querySelectorAll("main.study form[method=post]")) {
    form.addEventListener("submit", (event) => {
      if (form.dataset.sent === "yes") {
        event.preventDefault();
        return;
      }
      form.dataset.sent = "yes";
    });
  }
  // Back from the browser's cache (the back button): the form may be sent again.
  window.addEventListener("pageshow", (event) => {
    if (event.persisted) for (const form of document.querySelectorAll("form[data-sent]")) delete form.dataset.sent;
  });
})();
