// The Collective Interface: draws each streamed frame and sends the
// participant's clicks, requests and probe answers. No framework, no build.
(function () {
  "use strict";
  const SVG = "http://www.w3.org/2000/svg";
  const ROMAN = ["I", "II", "III", "IV", "V", "VI"];
  const HUB = 96, TARGET = 56;
  const root = document.getElementById("interface");
  const apiUrl = root.dataset.apiUrl;
  const csrf = document.querySelector('meta[name="csrf-token"]').content;
  const $ = (id) => document.getElementById(id);
  const state = {
    view: null, probe: null, selectedHub: null, selectedTarget: null,
    selectedAssignment: null, selections: { collective: null, target: null },
    flag: null, ended: false, seenMessages: new Set(),
  };

  function el(name, attrs, parent) {
    const node = document.createElementNS(SVG, name);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
    if (parent) parent.appendChild(node);
    return node;
  }
  function clock(seconds) {
    const s = Math.max(0, Math.floor(seconds));
    return Math.floor(s / 60) + ":" + String(s % 60).padStart(2, "0");
  }
  async function post(path, body) {
    const response = await fetch(apiUrl + path, {
      method: "POST", credentials: "same-origin",
      headers: { "Content-Type": "application/json", "X-CSRFToken": csrf },
      body: JSON.stringify(body || {}),
    });
    let payload = {};
    try { payload = await response.json(); } catch (e) { /* empty body */ }
    if (!response.ok) throw new Error(payload.message || response.statusText);
    return payload;
  }
  function note(text) { $("request-note").textContent = text || ""; }

  // ---- map ---------------------------------------------------------------
  function drawMap(view) {
    const ranges = $("layer-ranges"), moves = $("layer-moves");
    const targets = $("layer-targets"), hubs = $("layer-collectives");
    for (const layer of [ranges, moves, targets, hubs]) layer.replaceChildren();
    const hub = state.selectedHub === null ? null : view.collectives[state.selectedHub];
    if (hub) el("circle", { cx: hub.hub[0], cy: -hub.hub[1], r: hub.range_m, class: "range" }, ranges);
    for (const t of view.targets) drawTarget(targets, t, hub);
    for (const c of view.collectives) {
      drawCollective(hubs, c);
      if (c.move) drawMove(moves, hubs, c, view);
    }
    drawFlag();
  }

  function drawTarget(layer, t, hub) {
    const [x, y] = [t.position[0], -t.position[1]];
    const classes = ["target"];
    if (!t.drawn) classes.push("undrawn");
    if (t.outline_executing) classes.push("executing");
    else if (t.outline_support) classes.push("support");
    if (state.selectedTarget === t.id) classes.push("selected");
    const g = el("g", { class: classes.join(" "), "data-target": t.id, transform: `translate(${x},${y})` }, layer);
    const h = TARGET / 2;
    if (t.drawn) {
      el("rect", { x: -h, y: -h, width: TARGET, height: h, class: "target-green", "fill-opacity": t.value ?? 0 }, g);
      el("rect", { x: -h, y: 0, width: TARGET, height: h, class: "target-blue", "fill-opacity": t.max_support }, g);
    } else {
      el("rect", { x: -h, y: -h, width: TARGET, height: TARGET, fill: "transparent" }, g);
    }
    el("rect", { x: -h, y: -h, width: TARGET, height: TARGET, class: "target-frame" }, g);
    el("text", { x: h + 18, y: -h + 4, class: "target-id" }, g).textContent = t.id;
    if (hub && t.in_range_of.includes(hub.index)) {
      const supported = t.support[hub.index] > 0;
      el("rect", { x: -h - 9, y: -h - 9, width: TARGET + 18, height: TARGET + 18,
        class: "range-mark " + (supported ? "supported" : "unsupported") }, g);
    }
    g.addEventListener("click", () => clickTarget(t.id, "left"));
    g.addEventListener("contextmenu", (e) => { e.preventDefault(); clickTarget(t.id, "right"); });
  }

  function drawCollective(layer, c) {
    const [x, y] = [c.hub[0], -c.hub[1]];
    const selected = state.selectedHub === c.index ? " selected" : "";
    const g = el("g", { class: "collective" + selected, "data-collective": c.index, transform: `translate(${x},${y})` }, layer);
    const h = HUB / 2, q = HUB / 2;
    el("text", { x: 0, y: -h - 10, class: "hub-name" }, g).textContent = ROMAN[c.index];
    el("rect", { x: -h, y: -h, width: HUB, height: HUB, class: "hub-box" }, g);
    const quads = [["U", -h, -h], ["F", 0, -h], ["C", -h, 0], ["X", 0, 0]];
    for (const [name, qx, qy] of quads) {
      el("rect", { x: qx, y: qy, width: q, height: q, class: "quad", "fill-opacity": c.fractions[name] }, g);
      el("text", { x: qx + q / 2, y: qy + q / 2, class: "quad-label" }, g).textContent = name;
    }
    g.addEventListener("click", () => clickHub(c.index, "left"));
    g.addEventListener("contextmenu", (e) => { e.preventDefault(); clickHub(c.index, "right"); });
  }

  function drawMove(moves, layer, c, view) {
    const target = view.targets.find((t) => t.id === c.move.target);
    if (target) el("line", { x1: c.hub[0], y1: -c.hub[1], x2: target.position[0], y2: -target.position[1], class: "move-line" }, moves);
    const [x, y] = [c.move.position[0], -c.move.position[1]];
    const g = el("g", { class: "moving", transform: `translate(${x},${y})` }, layer);
    el("rect", { x: -30, y: -30, width: 60, height: 60, class: "move-box" }, g);
    el("text", { x: 0, y: 10, class: "quad-label" }, g).textContent = ROMAN[c.index];
  }

  function drawFlag() {
    const layer = $("layer-flags");
    layer.replaceChildren();
    const view = state.view;
    if (!state.flag || !view) return;
    let anchor, lines;
    if (state.flag.kind === "target") {
      const t = view.targets.find((x) => x.id === state.flag.id);
      if (!t) { state.flag = null; return; }
      anchor = t.position;
      lines = [`Target ${t.id}: support`].concat(
        t.support.map((s, i) => `${ROMAN[i]}: ${Math.round(s * 100)}%`));
    } else {
      const c = view.collectives[state.flag.id];
      anchor = c.hub;
      lines = [`Collective ${ROMAN[c.index]}`].concat(
        ["U", "F", "C", "X"].map((k) => `${k}: ${c.counts[k]}`));
    }
    const g = el("g", { class: "flag", transform: `translate(${anchor[0] + 50},${-anchor[1] - 40})` }, layer);
    el("rect", { x: 0, y: 0, width: 230, height: 26 * lines.length + 12, rx: 6 }, g);
    lines.forEach((line, i) => { el("text", { x: 12, y: 28 + 26 * i }, g).textContent = line; });
    g.addEventListener("click", () => { state.flag = null; drawFlag(); });
  }

  // ---- clicks: selection and observation actions --------------------------
  async function observe(body) {
    try { return (await post("/observations", body)).observation_id; }
    catch (e) { note(e.message); return null; }
  }
  async function clickHub(index, button) {
    if (state.ended) return;
    if (button === "left") {
      state.selectedHub = index;
      $("request-collective").value = String(index);
    } else {
      state.flag = { kind: "collective", id: index };
    }
    if (state.view) drawMap(state.view);
    const id = await observe({ kind: "collective", collective: index, button });
    if (button === "left") state.selections.collective = { id, value: String(index) };
  }
  async function clickTarget(targetId, button) {
    if (state.ended) return;
    if (button === "left") {
      state.selectedTarget = targetId;
      refreshTargetOptions();
      $("request-target").value = String(targetId);
    } else {
      state.flag = { kind: "target", id: targetId };
    }
    if (state.view) drawMap(state.view);
    const id = await observe({ kind: "target", target: targetId, button });
    if (button === "left") state.selections.target = { id, value: String(targetId) };
  }

  // ---- Collective Requests -------------------------------------------------
  function refreshCollectiveOptions(view) {
    const select = $("request-collective");
    if (select.options.length - 1 === view.collectives.length) return;
    select.replaceChildren(new Option("–", ""));
    for (const c of view.collectives) select.add(new Option(ROMAN[c.index], String(c.index)));
  }
  function refreshTargetOptions() {
    const select = $("request-target"), keep = select.value;
    const ids = (state.view ? state.view.targets : []).map((t) => t.id).sort((a, b) => a - b);
    const current = Array.from(select.options).slice(1).map((o) => Number(o.value));
    if (JSON.stringify(current) !== JSON.stringify(ids)) {
      select.replaceChildren(new Option("–", ""));
      for (const id of ids) select.add(new Option(String(id), String(id)));
      select.value = ids.includes(Number(keep)) ? keep : "";
    }
  }
  function resetForm() {
    $("request-form").reset();
    state.selectedHub = null; state.selectedTarget = null;
    state.selections = { collective: null, target: null };
    note("");
    if (state.view) drawMap(state.view);
  }
  async function commit(event) {
    event.preventDefault();
    const kind = $("request-kind").value, collective = $("request-collective").value;
    const target = $("request-target").value;
    if (!kind || collective === "" || target === "") { note("Choose a type, a collective and a target."); return; }
    // Clicks that filled the form are part of this request, not observations.
    const selections = [];
    for (const [slot, value] of [["collective", collective], ["target", target]]) {
      const s = state.selections[slot];
      if (s && s.id !== null && s.value === value) selections.push(s.id);
    }
    try {
      const outcome = await post("/requests", { kind, collective: Number(collective), target: Number(target), selections });
      note(outcome.accepted ? `Request ${outcome.request_id} accepted.` : `Refused: ${outcome.reason}`);
      if (outcome.accepted) resetForm();
    } catch (e) { note(e.message); }
  }

  // ---- Collective Assignments ------------------------------------------------
  function drawAssignments(view) {
    const list = $("assignments");
    list.replaceChildren();
    if (!view.requests.some((r) => r.id === state.selectedAssignment)) state.selectedAssignment = null;
    for (const r of view.requests) {
      const li = document.createElement("li");
      li.dataset.request = r.id; li.dataset.kind = r.kind;
      if (r.id === state.selectedAssignment) li.classList.add("selected");
      const dot = document.createElement("span");
      dot.className = "dot " + r.status; dot.title = r.status.replace("_", " ");
      const label = document.createElement("span");
      label.textContent = `${r.kind} · ${ROMAN[r.collective]} → target ${r.target}`;
      li.append(dot, label);
      li.addEventListener("click", () => { state.selectedAssignment = r.id; drawAssignments(view); });
      list.appendChild(li);
    }
    const selected = view.requests.find((r) => r.id === state.selectedAssignment);
    $("cancel-assignment").disabled = !(selected && selected.kind === "abandon");
  }
  async function cancelAssignment() {
    if (state.selectedAssignment === null) return;
    try {
      const outcome = await post("/requests", { kind: "cancel", request_id: state.selectedAssignment });
      note(outcome.accepted ? "Assignment cancelled." : `Refused: ${outcome.reason}`);
    } catch (e) { note(e.message); }
  }

  // ---- System Messages -----------------------------------------------------
  function addMessages(messages) {
    const list = $("messages");
    for (const m of messages) {
      if (state.seenMessages.has(m.seq)) continue;
      state.seenMessages.add(m.seq);
      const li = document.createElement("li");
      li.className = m.kind;
      const time = document.createElement("time");
      time.textContent = clock(m.time);
      li.append(time, document.createTextNode(m.text));
      list.prepend(li);
    }
  }

  // ---- SA probes --------------------------------------------------------------
  function drawProbe(probe) {
    const box = $("probe");
    const key = probe ? probe.id + ":" + probe.phase : null;
    if (key === state.probeKey) return;
    state.probeKey = key;
    box.hidden = !probe;
    if (!probe) return;
    box.dataset.probe = probe.id;
    box.querySelector(".probe-ready").hidden = probe.phase !== "ready";
    box.querySelector(".probe-question").hidden = probe.phase !== "question";
    if (probe.phase === "question") {
      $("probe-text").textContent = probe.question;
      const choices = $("probe-choices");
      choices.replaceChildren();
      for (const choice of probe.choices) {
        const button = document.createElement("button");
        button.type = "button"; button.textContent = choice; button.dataset.answer = choice;
        button.addEventListener("click", () => answerProbe(probe.id, choice));
        choices.appendChild(button);
      }
    }
  }
  async function readyProbe() {
    const id = Number($("probe").dataset.probe);
    try { await post(`/probes/${id}/ready`); } catch (e) { note(e.message); }
  }
  async function answerProbe(id, answer) {
    try { await post(`/probes/${id}/answer`, { answer }); $("probe").hidden = true; }
    catch (e) { note(e.message); }
  }

  // ---- the stream ---------------------------------------------------------------
  function onFrame(frame) {
    $("clock").textContent = clock(frame.trial.clock_s);
    if (frame.messages) addMessages(frame.messages);
    if (frame.view) {
      state.view = frame.view;
      refreshCollectiveOptions(frame.view);
      refreshTargetOptions();
      drawMap(frame.view);
      drawAssignments(frame.view);
    }
    drawProbe(frame.probe || null);
    if (frame.trial.status === "ended") endTrial();
  }
  function endTrial() {
    state.ended = true;
    if (stream) stream.close();
    $("probe").hidden = true;
    $("ended").hidden = false;
    $("commit").disabled = true;
    $("connection").textContent = "trial over";
    const next = root.dataset.continueUrl;
    if (next) { $("continue").href = next; $("continue").hidden = false; }
  }

  let stream = null;
  function connect() {
    stream = new EventSource(root.dataset.streamUrl);
    stream.onopen = () => { $("connection").textContent = "live"; $("connection").className = "connection ok"; };
    stream.onerror = () => { if (!state.ended) { $("connection").textContent = "reconnecting…"; $("connection").className = "connection"; } };
    stream.onmessage = (event) => onFrame(JSON.parse(event.data));
  }

  $("request-form").addEventListener("submit", commit);
  $("reset").addEventListener("click", resetForm);
  $("cancel-assignment").addEventListener("click", cancelAssignment);
  $("probe-ready").addEventListener("click", readyProbe);
  $("map").addEventListener("contextmenu", (e) => e.preventDefault());
  $("request-collective").addEventListener("change", (e) => {
    state.selectedHub = e.target.value === "" ? null : Number(e.target.value);
    if (state.view) drawMap(state.view);
  });
  $("request-target").addEventListener("change", (e) => {
    state.selectedTarget = e.target.value === "" ? null : Number(e.target.value);
    if (state.view) drawMap(state.view);
  });
  if (root.dataset.status === "ended") endTrial();
  connect();
})();
