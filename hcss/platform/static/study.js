// Counts down the time left on a timed study page. The deadline is the
// server's: at zero the page reloads and the server records the time-out.
(() => {
  "use strict";
  const timer = document.getElementById("timer");
  if (!timer) return;
  const end = Date.now() + parseFloat(timer.dataset.remainingWallS) * 1000;
  const scale = parseFloat(timer.dataset.studyPerWall || "1");
  const shown = document.getElementById("time-left");
  function tick() {
    const left = Math.max(0, (end - Date.now()) / 1000);
    const s = Math.ceil(left * scale);
    shown.textContent = `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
    if (left <= 0) {
      window.location.replace(window.location.pathname.replace(/\/stage\/.*$/, "/stage"));
      return;
    }
    window.setTimeout(tick, 250);
  }
  tick();
})();
