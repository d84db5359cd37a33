// Tell the server this participant's page is open (the experimenter's console shows it), and
// move on when the server answers that the experimenter skipped the step shown.
// Loaded by every participant page; the script tag carries the heartbeat URL.
(() => {
  "use strict";
  const script = document.currentScript;
  const url = script?.dataset.heartbeatUrl;
  if (!url) return;
  const everyMs = Number(script.dataset.everyS || 10) * 1000;
  const page = document.getElementById("interface") ? "trial" : "study";

  // A study page's form posts to /p/<token>/stage/<index>/<step>: the step it shows.
  const form = document.querySelector('main form[method="post"][action*="/stage/"]');
  const shown = form?.getAttribute("action").match(/\/stage\/(\d+)\/([a-z0-9_]+)$/);
  let moving = false;

  // The experimenter skipped the step this page shows: move on by itself. Answers already
  // given are sent (the server keeps them apart and says so); an untouched page just goes on.
  function moveOn() {
    if (moving) return;
    moving = true;
    const given = Array.from(form.elements).some(
      (field) =>
        field.name &&
        field.name !== "csrf_token" &&
        field.type !== "hidden" &&
        field.type !== "submit" &&
        field.type !== "button" &&
        (field.type === "checkbox" || field.type === "radio" ? field.checked : field.value),
    );
    if (given) {
      HTMLFormElement.prototype.submit.call(form);
    } else {
      window.location.assign(form.getAttribute("action").replace(/\/\d+\/[a-z0-9_]+$/, ""));
    }
  }

  function beat() {
    const fields = { page: page, hidden: document.visibilityState === "hidden" };
    if (shown) {
      fields.stage = Number(shown[1]);
      fields.step = shown[2];
    }
    fetch(url, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(fields),
      credentials: "same-origin",
      keepalive: true,
    })
      .then((response) => {
        if (response.status !== 200) return null;
        return response.json().then((answer) => {
          if (answer?.moved_on && shown) moveOn();
        });
      })
      .catch(() => {
        // Offline for a moment: the next beat tells the console again.
      });
  }

  beat();
  setInterval(beat, everyMs);
  document.addEventListener("visibilitychange", beat);
})();
