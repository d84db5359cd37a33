// A form that posts is sent once per page: a double click on a study page's
// Continue sent it twice, and the second copy, refused by the server as
// already submitted, showed the participant an alarming "this page has
// already been submitted"; on the console, a double click on Create made two
// batches of links while the server was slow to answer the first. The clicked
// button keeps its name and value (it is not disabled, the form just ignores
// further submits); the server still refuses any repeat it must.
// Loaded in <head> and listening on the document, so it guards every form from
// the moment the page starts to render (a listener added per form at the end of
// <body> left a window before it ran). A submit is held back in the capture
// phase; a form counts as sent only if no handler of the page cancelled the
// submit (a confirm the user declined), so a form the user has not sent is never
// locked.
(() => {
  "use strict";
  const posts = (target) => target instanceof HTMLFormElement && target.method === "post";
  document.addEventListener(
    "submit",
    (event) => {
      if (posts(event.target) && event.target.dataset.sent === "yes") event.preventDefault();
    },
    true,
  );
  document.addEventListener("submit", (event) => {
    if (posts(event.target) && !event.defaultPrevented) event.target.dataset.sent = "yes";
  });
  // Back from the browser's cache (the back button): the form may be sent again.
  window.addEventListener("pageshow", (event) => {
    if (event.persisted) for (const form of document.querySelectorAll("form[data-sent]")) delete form.dataset.sent;
  });
})();
