// Refresh the live participant table every two seconds from /console/progress.json.
(function () {
  "use strict";
  const table = document.getElementById("progress");
  if (!table) return;
  const body = table.querySelector("tbody");
  const minutes = (s) => Math.floor(s / 60) + ":" + String(Math.floor(s % 60)).padStart(2, "0");

  function cell(text, className) {
    const td = document.createElement("td");
    td.textContent = text;
    if (className) td.className = className;
    return td;
  }

  function render(participants) {
    body.replaceChildren();
    if (participants.length === 0) {
      const row = document.createElement("tr");
      const td = cell("No participants yet.");
      td.colSpan = 6;
      row.append(td);
      body.append(row);
      return;
    }
    for (const p of participants) {
      const row = document.createElement("tr");
      row.dataset.code = p.code;
      const link = document.createElement("a");
      link.href = table.dataset.participantUrl.replace("CODE", encodeURIComponent(p.code));
      link.textContent = p.code;
      const first = document.createElement("td");
      first.append(link);
      const clock = p.trial_clock_s === null ? "–"
        : minutes(p.trial_clock_s) + " / " + Math.floor(p.trial_duration_s / 60) + " min";
      const flags = [p.is_pilot && "pilot", p.is_bot && "bot", p.is_demo && "demo"].filter(Boolean);
      row.append(first, cell(p.state, "state-" + p.state), cell(p.stage),
                 cell(minutes(p.time_in_stage_s)), cell(clock), cell(flags.join(" ")));
      body.append(row);
    }
  }

  async function poll() {
    try {
      const response = await fetch(table.dataset.url, { credentials: "same-origin" });
      if (response.ok) render((await response.json()).participants);
    } catch (error) {
      // A dropped poll is retried by the next one.
    }
  }
  setInterval(poll, 2000);
})();
