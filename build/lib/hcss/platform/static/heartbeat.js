// Tell the server this participant's page is open (the experimenter's console shows it).
// Loaded by every participant page; the script tag carries the heartbeat URL.
(function () {
  "use strict";
  const script = document.currentScript;
  const url = script && script.dataset.heartbeatUrl;
  if (!url) return;
  const everyMs = Number(script.dataset.everyS || 10) * 1000;
  const page = document.getElementById("interface") ? "trial" : "study";

  function beat() {
    const body = JSON.stringify({ page: page, hidden: document.visibilityState === "hidden" });
    fetch(url, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: body,
      credentials: "same-origin",
      keepalive: true,
    }).catch(function () {
      // Offline for a moment: the next beat tells the console again.
    });
  }

  beat();
  setInterval(beat, everyMs);
  document.addEventListener("visibilitychange", beat);
})();
