// The participant page's small behaviours, kept out of the HTML so the
// Content-Security-Policy can forbid inline script (hcss/platform/guards/hardening.py).
(() => {
  "use strict";
  document.querySelectorAll("input.link").forEach((input) => {
    input.addEventListener("focus", () => input.select());
  });
  document.querySelectorAll("button[data-confirm]").forEach((button) => {
    button.addEventListener("click", (event) => {
      if (!window.confirm(button.dataset.confirm)) event.preventDefault();
    });
  });
})();
