// The screen check (templates/study/screen_check.html): a file, not inline, for the CSP.
(() => {
  "use strict";
  const status = document.getElementById("screen-status");
  const minW = Number(status.dataset.minWidth),
    minH = Number(status.dataset.minHeight);
  const modern =
    "EventSource" in window &&
    "fetch" in window &&
    !!document.createElementNS &&
    !!(window.crypto && crypto.getRandomValues);
  function check() {
    const w = window.innerWidth,
      h = window.innerHeight;
    const big = w >= minW && h >= minH;
    document.getElementById("screen-width").value = w;
    document.getElementById("screen-height").value = h;
    document.getElementById("screen-size").textContent = `${w} x ${h}`;
    document.getElementById("screen-too-small").hidden = big;
    document.getElementById("browser-too-old").hidden = modern;
    document.getElementById("screen-ok").hidden = !(big && modern);
    document.getElementById("screen-continue").disabled = !(big && modern);
  }
  window.addEventListener("resize", check);
  check();
})();
