// The Collective Interface: draws each streamed frame and sends the
// participant's clicks, requests and probe answers. No framework, no build.
(() => {
  "use strict";
  const SVG = "http://www.w3.org/2000/svg";
  // Glyph sizes in screen pixels: the map scales positions to the window, but a
  // hub, a target and their labels keep a size that can be read and clicked.
  const HUB = 56,
    TARGET = 30;
  // The arena is 2 x ARENA metres square, centred on the origin.
  const ARENA = 707;
  const root = document.getElementById("interface");
  // Collective names come from the server (hcss.simulation.messages), as in its System Messages.
  const NAMES = JSON.parse(root.dataset.collectiveNames);
  // The console's replay page (status "replay") feeds recorded frames to onFrame; nothing is sent.
  const replaying = root.dataset.status === "replay";
  const apiUrl = root.dataset.apiUrl;
  const csrf = document.querySelector('meta[name="csrf-token"]').content;
  const $ = (id) => document.getElementById(id);
  const state = {
    view: null,
    probe: null,
    selectedHub: null,
    selectedTarget: null,
    selectedAssignment: null,
    selections: { collective: null, target: null },
    flag: null,
    ended: false,
    paused: false,
    committing: false,
    seenMessages: new Set(),
    shownClockS: -Infinity, // the newest trial clock shown; a frame behind it is held
  };

  function el(name, attrs, parent) {
    const node = document.createElementNS(SVG, name);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
    if (parent) parent.appendChild(node);
    return node;
  }
  function clock(seconds) {
    const s = Math.max(0, Math.floor(seconds));
    return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
  }
  // Every command carries a fresh Idempotency-Key: the server carries out a
  // key once and answers a repeat (a double click, a retry) with the first
  // outcome. getRandomValues works on plain http too, unlike randomUUID.
  function newKey() {
    const bytes = crypto.getRandomValues(new Uint8Array(16));
    return Array.from(bytes, (b) => b.toString(16).padStart(2, "0")).join("");
  }
  // A 503 holds a command back without storing it (the database is away, or the
  // trial is moving to another server process; the body's held_by says which):
  // the page sends it again with the same key after 0.5 s, doubling up to the
  // answer's Retry-After, for at most HELD_LIMIT_S, and says why it waits.
  const HELD_LIMIT_S = 60;
  const HELD_NOTICE = {
    database: "The study's database is not answering just now",
    server: "The trial is moving to another server",
  };
  // Answers that say "not now", not "no": 503 from the server (database away,
  // trial moving), 502 and 504 from a proxy whose process died with the request
  // in flight (the command may be stored, its answer lost). The same
  // Idempotency-Key again either stores it once or returns the first answer.
  const PASSING_STATUS = new Set([502, 503, 504]);
  const pause = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
  async function post(path, body) {
    if (replaying) throw new Error("This is a replay: nothing is sent.");
    const key = newKey();
    const started = Date.now();
    for (let attempt = 0, held = 0; ; attempt++) {
      let response;
      try {
        response = await fetch(apiUrl + path, {
          method: "POST",
          credentials: "same-origin",
          headers: { "Content-Type": "application/json", "X-CSRFToken": csrf, "Idempotency-Key": key },
          body: JSON.stringify(body || {}),
        });
      } catch (_e) {
        // the connection dropped: the same key again is safe
        if (attempt >= 2) throw new Error("No connection to the server; please try again.");
        await pause(300 * (attempt + 1));
        continue;
      }
      let payload = {};
      try {
        payload = await response.json();
      } catch (_e) {
        /* empty body */
      }
      if (response.ok) return payload;
      const waitS = Math.min(0.5 * 2 ** held, retryAfterS(response));
      if (
        !PASSING_STATUS.has(response.status) ||
        state.ended ||
        Date.now() - started + waitS * 1000 > HELD_LIMIT_S * 1000
      ) {
        throw new Error(payload.message || response.statusText);
      }
      held++;
      const why = HELD_NOTICE[payload.held_by] || "The server is busy just now";
      note(`${why}: sending again in ${Math.ceil(waitS)} s…`);
      await pause(waitS * 1000);
    }
  }
  // A button that sends a command is disabled until its answer is in.
  async function inFlight(buttons, action) {
    if (buttons.some((b) => b.disabled)) return;
    buttons.forEach((b) => {
      b.disabled = true;
    });
    try {
      await action();
    } catch (e) {
      note(e.message);
    } finally {
      buttons.forEach((b) => {
        b.disabled = false;
      });
    }
  }
  function note(text, ok) {
    $("request-note").textContent = text || "";
    $("request-note").classList.toggle("ok", !!ok);
  }

  // ---- map ---------------------------------------------------------------
  // Glyphs are created once per collective or target and updated in place:
  // replacing them at every frame would lose a click whose mousedown and
  // mouseup land on two different copies.
  const glyphs = { target: new Map(), collective: new Map(), move: new Map() };

  function syncLayer(kind, items, key, create, update, layer) {
    const seen = new Set();
    for (const item of items) {
      const id = key(item);
      seen.add(id);
      let glyph = glyphs[kind].get(id);
      if (!glyph) {
        glyph = create(item, layer);
        glyphs[kind].set(id, glyph);
      }
      update(glyph, item);
    }
    for (const [id, glyph] of glyphs[kind]) {
      if (!seen.has(id)) {
        glyph.root.remove();
        glyph.labels?.remove();
        glyphs[kind].delete(id);
      }
    }
  }

  // ---- scale: the arena fills the panel's shorter side, the ground the rest ----
  // World metres per screen pixel; glyphs are drawn in pixels and scaled by it.
  // Zoom and pan (buttons, wheel, drag, keys) move the world under the glyphs:
  // a zoomed map spreads crowded targets apart while every label keeps its size.
  let metresPerPx = 1;
  const ZOOM_STEP = 1.5,
    ZOOM_MAX = 4,
    PAN_PX = 80,
    DRAG_PX = 4;
  const camera = { zoom: 1, x: 0, y: 0 }; // the view's centre, in SVG units (y down)
  function fitMap() {
    const map = $("map"),
      box = map.getBoundingClientRect();
    if (!box.width || !box.height) return;
    metresPerPx = (2 * ARENA) / Math.min(box.width, box.height) / camera.zoom;
    const w = box.width * metresPerPx,
      h = box.height * metresPerPx;
    // The view's centre stays over the arena, so the map cannot be lost off the panel.
    camera.x = Math.max(-ARENA, Math.min(ARENA, camera.x));
    camera.y = Math.max(-ARENA, Math.min(ARENA, camera.y));
    if (camera.zoom === 1) {
      camera.x = 0;
      camera.y = 0;
    }
    const extent = [camera.x - w / 2, camera.y - h / 2, w, h];
    map.setAttribute("viewBox", extent.join(" "));
    const ground = map.querySelector(".ground");
    for (const [k, v] of Object.entries({ x: extent[0], y: extent[1], width: w, height: h })) ground.setAttribute(k, v);
    $("zoom-out").disabled = camera.zoom <= 1;
    $("zoom-in").disabled = camera.zoom >= ZOOM_MAX;
    $("zoom-reset").disabled = camera.zoom === 1;
    $("map").dataset.zoom = camera.zoom.toFixed(3);
    if (state.view) drawMap(state.view);
    placeProbe();
  }
  // Zoom by `factor`, keeping the map point under (clientX, clientY) where it is;
  // without a point, about the view's centre.
  function zoomBy(factor, clientX, clientY) {
    const zoom = Math.max(1, Math.min(ZOOM_MAX, camera.zoom * factor));
    if (zoom === camera.zoom) return;
    const box = $("map").getBoundingClientRect();
    const dx = clientX === undefined ? 0 : clientX - (box.left + box.width / 2);
    const dy = clientY === undefined ? 0 : clientY - (box.top + box.height / 2);
    const before = metresPerPx;
    const after = (before * camera.zoom) / zoom;
    camera.x += dx * (before - after);
    camera.y += dy * (before - after);
    camera.zoom = zoom;
    fitMap();
  }
  function panBy(dxPx, dyPx) {
    if (camera.zoom === 1) return;
    camera.x -= dxPx * metresPerPx;
    camera.y -= dyPx * metresPerPx;
    fitMap();
  }
  function resetZoom() {
    camera.zoom = 1;
    fitMap();
  }
  // A drag pans; a press that does not move is a click on whatever is under it.
  let drag = null;
  function startDrag(e) {
    if (e.button !== 0 || camera.zoom === 1) return;
    drag = { x: e.clientX, y: e.clientY, moved: false, id: e.pointerId };
  }
  function moveDrag(e) {
    if (!drag || e.pointerId !== drag.id) return;
    const dx = e.clientX - drag.x,
      dy = e.clientY - drag.y;
    if (!drag.moved && Math.hypot(dx, dy) < DRAG_PX) return;
    if (!drag.moved) {
      drag.moved = true;
      $("map").setPointerCapture(e.pointerId);
      $("map").classList.add("dragging");
    }
    drag.x = e.clientX;
    drag.y = e.clientY;
    panBy(dx, dy);
  }
  function endDrag(e) {
    if (!drag || e.pointerId !== drag.id) return;
    const moved = drag.moved;
    drag = null;
    $("map").classList.remove("dragging");
    // The click that ends a drag selects nothing and is no observation.
    if (moved)
      window.addEventListener(
        "click",
        (c) => {
          c.stopPropagation();
          c.preventDefault();
        },
        { capture: true, once: true },
      );
  }
  // Keys anywhere on the map (a hub or target focused, or the zoom buttons):
  // + and - zoom, 0 resets, the arrow keys pan.
  const PAN_KEYS = { ArrowLeft: [1, 0], ArrowRight: [-1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
  function mapKeys(e) {
    if (e.altKey || e.ctrlKey || e.metaKey) return;
    if (e.key === "+" || e.key === "=") zoomBy(ZOOM_STEP);
    else if (e.key === "-" || e.key === "_") zoomBy(1 / ZOOM_STEP);
    else if (e.key === "0") resetZoom();
    else if (PAN_KEYS[e.key] && camera.zoom > 1) panBy(PAN_KEYS[e.key][0] * PAN_PX, PAN_KEYS[e.key][1] * PAN_PX);
    else return;
    e.preventDefault();
  }
  // A glyph's transform: at its world position, drawn in pixels.
  function placed(x, y) {
    return `translate(${x},${-y}) scale(${metresPerPx})`;
  }

  function drawMap(view) {
    const hub = state.selectedHub === null ? null : view.collectives[state.selectedHub];
    const ranges = $("layer-ranges");
    ranges.replaceChildren();
    if (hub) el("circle", { cx: hub.hub[0], cy: -hub.hub[1], r: hub.range_m, class: "range" }, ranges);
    syncLayer(
      "target",
      view.targets,
      (t) => t.id,
      createTarget,
      (g, t) => updateTarget(g, t, hub),
      $("layer-targets"),
    );
    separateTargetLabels(view.targets);
    syncLayer(
      "collective",
      view.collectives,
      (c) => c.index,
      createCollective,
      updateCollective,
      $("layer-collectives"),
    );
    syncLayer(
      "move",
      view.collectives.filter((c) => c.move),
      (c) => c.index,
      createMove,
      (g, c) => updateMove(g, c, view),
      $("layer-moves"),
    );
    drawFlag();
  }

  // Hubs and targets are buttons for the keyboard too: Tab reaches them, Enter or
  // Space is a left click, and "i", the context-menu key or Shift+F10 a right click.
  function makeKeyboardButton(node, label, onClick) {
    node.setAttribute("tabindex", "0");
    node.setAttribute("role", "button");
    node.setAttribute("aria-label", label);
    node.addEventListener("keydown", (e) => {
      if (e.key === "Enter" || e.key === " ") {
        e.preventDefault();
        onClick("left");
      } else if (e.key === "i" || e.key === "ContextMenu" || (e.key === "F10" && e.shiftKey)) {
        e.preventDefault();
        onClick("right");
      }
    });
  }

  function createTarget(t, layer) {
    const h = TARGET / 2;
    const root = el("g", { "data-target": t.id });
    // In id order, so Tab meets the targets by number, after the hubs.
    const next = Array.from(layer.children).find((g) => Number(g.dataset.target) > t.id);
    layer.insertBefore(root, next || null);
    const glyph = {
      root,
      hit: el("rect", { x: -h, y: -h, width: TARGET, height: TARGET, fill: "transparent" }, root),
      green: el("rect", { x: -h, y: -h, width: TARGET, height: h, class: "target-green" }, root),
      blue: el("rect", { x: -h, y: 0, width: TARGET, height: h, class: "target-blue" }, root),
      frame: el("rect", { x: -h, y: -h, width: TARGET, height: TARGET, class: "target-frame" }, root),
      mark: el("rect", { x: -h - 5, y: -h - 5, width: TARGET + 10, height: TARGET + 10, class: "range-mark" }, root),
    };
    glyph.leader = el("line", { class: "target-leader", display: "none" }, root);
    glyph.label = el("text", { x: LABEL_SPOTS[0][0], y: LABEL_SPOTS[0][1], class: "target-id" }, root);
    glyph.label.textContent = t.id;
    root.addEventListener("click", () => clickTarget(t.id, "left"));
    root.addEventListener("contextmenu", (e) => {
      e.preventDefault();
      clickTarget(t.id, "right");
    });
    makeKeyboardButton(root, `Target ${t.id}`, (button) => clickTarget(t.id, button));
    return glyph;
  }

  // A target's number sits at its top right. Where targets crowd together (two
  // found at almost the same place), a number there would be drawn under a
  // neighbour or over its number, while a probe may be asking about either; so
  // each number takes the first of these spots (the end of its text, in screen
  // pixels from the target's centre) that is clear of the other targets and of
  // the numbers placed before it, in id order. A spot away from the box gets a
  // leader line to it. Apart from crowding every number stays at the first spot.
  const LABEL_SPOTS = [
    [29, -12, false],
    [29, 31, false],
    [-19, -20, false],
    [-19, 31, false],
    [52, -34, true],
    [-42, -42, true],
    [52, 54, true],
    [-42, 56, true],
    [0, -48, true],
    [0, 70, true],
  ];
  const LABEL_H = 16;
  function labelBox(cx, cy, spot, digits) {
    const w = 10 * digits + 2;
    return [cx + spot[0] - w, cy + spot[1] - LABEL_H + 3, cx + spot[0], cy + spot[1] + 3];
  }
  function overlap(a, b) {
    const x = Math.min(a[2], b[2]) - Math.max(a[0], b[0]);
    const y = Math.min(a[3], b[3]) - Math.max(a[1], b[1]);
    return x > 0 && y > 0 ? x * y : 0;
  }
  function separateTargetLabels(targets) {
    const h = TARGET / 2;
    const at = targets.map((t) => [t.id, t.position[0] / metresPerPx, -t.position[1] / metresPerPx]);
    const boxes = at.map(([, x, y]) => [x - h, y - h, x + h, y + h]);
    const placed = [];
    for (const [index, [id, x, y]] of at.entries()) {
      const glyph = glyphs.target.get(id);
      if (!glyph) continue;
      const digits = String(id).length;
      let best = null;
      for (const spot of LABEL_SPOTS) {
        const box = labelBox(x, y, spot, digits);
        let cost = 0;
        for (const [other, b] of boxes.entries()) if (other !== index) cost += overlap(box, b);
        for (const b of placed) cost += overlap(box, b);
        if (best === null || cost < best[0]) best = [cost, spot, box];
        if (cost === 0) break;
      }
      const [, spot, box] = best;
      placed.push(box);
      glyph.label.setAttribute("x", spot[0]);
      glyph.label.setAttribute("y", spot[1]);
      glyph.leader.setAttribute("display", spot[2] ? "" : "none");
      if (spot[2]) {
        const [ex, ey] = [Math.max(-h, Math.min(h, spot[0] - 5 * digits)), Math.max(-h, Math.min(h, spot[1] - 5))];
        const end = [spot[0] - 5 * digits, spot[1] - 5];
        for (const [k, v] of Object.entries({ x1: ex, y1: ey, x2: end[0], y2: end[1] }))
          glyph.leader.setAttribute(k, v);
      }
    }
  }

  function updateTarget(glyph, t, hub) {
    const classes = ["target"];
    if (!t.drawn) classes.push("undrawn");
    if (t.outline_executing) classes.push("executing");
    else if (t.outline_support) classes.push("support");
    if (state.selectedTarget === t.id) classes.push("selected");
    glyph.root.setAttribute("class", classes.join(" "));
    glyph.root.setAttribute("transform", placed(t.position[0], t.position[1]));
    const label =
      `Target ${t.id}` +
      (t.drawn ? `, highest support ${Math.round(t.max_support * 100)}%` : ", not yet reported") +
      (state.selectedTarget === t.id ? ", selected" : "");
    if (glyph.root.getAttribute("aria-label") !== label) glyph.root.setAttribute("aria-label", label);
    // Transparent until two agents have reported it.
    glyph.green.setAttribute("fill-opacity", t.drawn ? (t.value ?? 0) : 0);
    glyph.blue.setAttribute("fill-opacity", t.drawn ? supportOpacity(t.max_support) : 0);
    const inRange = hub && t.in_range_of.includes(hub.index);
    glyph.mark.style.display = inRange ? "" : "none";
    if (inRange) {
      const supported = t.support[hub.index] > 0;
      glyph.mark.setAttribute("class", `range-mark ${supported ? "supported" : "unsupported"}`);
    }
  }

  // The blue half's opacity grows with the highest support, as the spec has it,
  // but from a floor: support of a few percent drawn at its own opacity (0.05)
  // is invisible on the ground (contrast 1.07:1). No support stays empty, so
  // "none" and "some" differ by a clear step; full support is fully opaque.
  const SUPPORT_FLOOR = 0.4;
  function supportOpacity(support) {
    return support > 0 ? SUPPORT_FLOOR + (1 - SUPPORT_FLOOR) * Math.min(1, support) : 0;
  }

  // A hub is a button (its box and quadrants) with its letters drawn over it in a group of
  // their own: letters inside the button would be its visible text, which its spoken label
  // ("Collective I hub") must then contain (WCAG 2.5.3, label in name).
  function createCollective(c, layer) {
    const h = HUB / 2,
      q = HUB / 2;
    const root = el("g", { "data-collective": c.index }, layer);
    const labels = el(
      "g",
      { class: "collective-labels", "data-collective-labels": c.index, "aria-hidden": "true" },
      layer,
    );
    el("text", { x: 0, y: -h - 6, class: "hub-name" }, labels).textContent = NAMES[c.index];
    el("rect", { x: -h, y: -h, width: HUB, height: HUB, class: "hub-box" }, root);
    const quads = {};
    for (const [name, qx, qy] of [
      ["U", -h, -h],
      ["F", 0, -h],
      ["C", -h, 0],
      ["X", 0, 0],
    ]) {
      quads[name] = el("rect", { x: qx, y: qy, width: q, height: q, class: "quad" }, root);
      el("text", { x: qx + q / 2, y: qy + q / 2, class: "quad-label" }, labels).textContent = name;
    }
    for (const node of [root, labels]) {
      node.addEventListener("click", () => clickHub(c.index, "left"));
      node.addEventListener("contextmenu", (e) => {
        e.preventDefault();
        clickHub(c.index, "right");
      });
    }
    makeKeyboardButton(root, `Collective ${NAMES[c.index]} hub`, (button) => clickHub(c.index, button));
    return { root, labels, quads };
  }

  function updateCollective(glyph, c) {
    glyph.root.setAttribute("class", `collective${state.selectedHub === c.index ? " selected" : ""}`);
    glyph.root.setAttribute("aria-pressed", state.selectedHub === c.index ? "true" : "false");
    glyph.root.setAttribute("transform", placed(c.hub[0], c.hub[1]));
    glyph.labels.setAttribute("transform", placed(c.hub[0], c.hub[1]));
    for (const name of ["U", "F", "C", "X"]) glyph.quads[name].setAttribute("fill-opacity", c.fractions[name]);
  }

  function createMove(c, layer) {
    const root = el("g", { class: "moving" }, layer);
    const line = el("line", { class: "move-line" }, root);
    const box = el("g", {}, root);
    el("rect", { x: -18, y: -18, width: 36, height: 36, class: "move-box" }, box);
    el("text", { x: 0, y: 0, class: "quad-label" }, box).textContent = NAMES[c.index];
    return { root, line, box };
  }

  function updateMove(glyph, c, view) {
    const target = view.targets.find((t) => t.id === c.move.target);
    const goal = target ? target.position : c.move.position;
    for (const [k, v] of Object.entries({ x1: c.hub[0], y1: -c.hub[1], x2: goal[0], y2: -goal[1] }))
      glyph.line.setAttribute(k, v);
    glyph.box.setAttribute("transform", placed(c.move.position[0], c.move.position[1]));
  }

  const FLAG_WIDTH = 180,
    FLAG_LINE = 21;
  function drawFlag() {
    const layer = $("layer-flags");
    const view = state.view;
    if (!state.flag || !view) {
      layer.replaceChildren();
      state.flagKey = null;
      return;
    }
    let anchor, lines;
    if (state.flag.kind === "target") {
      const t = view.targets.find((x) => x.id === state.flag.id);
      if (!t) {
        state.flag = null;
        layer.replaceChildren();
        state.flagKey = null;
        return;
      }
      anchor = t.position;
      lines = [`Target ${t.id}: support`].concat(t.support.map((s, i) => `${NAMES[i]}: ${Math.round(s * 100)}%`));
    } else {
      const c = view.collectives[state.flag.id];
      anchor = c.hub;
      lines = [`Collective ${NAMES[c.index]}`].concat(["U", "F", "C", "X"].map((k) => `${k}: ${c.counts[k]}`));
    }
    const key = JSON.stringify([anchor, lines, $("map").getAttribute("viewBox")]);
    if (key === state.flagKey) return;
    state.flagKey = key;
    layer.replaceChildren();
    // The box lets every click through to the map (pointer-events: none in live.css);
    // only its close control takes clicks. Escape closes it too.
    // Beside its hub or target, on the side with room, in pixels like the glyphs.
    const width = FLAG_WIDTH,
      height = FLAG_LINE * lines.length + 10;
    const right =
      Number($("map").getAttribute("viewBox").split(" ")[0]) + Number($("map").getAttribute("viewBox").split(" ")[2]);
    const dx = anchor[0] + (36 + width) * metresPerPx > right ? -36 - width : 36;
    const g = el("g", { class: "flag", transform: `${placed(anchor[0], anchor[1])} translate(${dx},-30)` }, layer);
    el("rect", { x: 0, y: 0, width, height, rx: 5 }, g);
    lines.forEach((line, i) => {
      el("text", { x: 10, y: 22 + FLAG_LINE * i }, g).textContent = line;
    });
    const close = el("g", { class: "flag-close", transform: `translate(${width - 26},4)` }, g);
    el("rect", { x: 0, y: 0, width: 22, height: 22, rx: 4 }, close);
    el("text", { x: 11, y: 17 }, close).textContent = "×";
    makeKeyboardButton(close, "Close the info box", () => closeFlag());
    close.addEventListener("click", (e) => {
      e.stopPropagation();
      closeFlag();
    });
    $("sr-status").textContent = lines.join(", ");
  }
  function closeFlag() {
    state.flag = null;
    drawFlag();
    $("sr-status").textContent = "Info box closed";
  }

  // ---- clicks: selection and observation actions --------------------------
  async function observe(body) {
    try {
      return (await post("/observations", body)).observation_id;
    } catch (e) {
      note(e.message);
      return null;
    }
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
    for (const c of view.collectives) select.add(new Option(NAMES[c.index], String(c.index)));
  }
  function refreshTargetOptions() {
    const select = $("request-target"),
      keep = select.value;
    const ids = (state.view ? state.view.targets : []).map((t) => t.id).sort((a, b) => a - b);
    const current = Array.from(select.options)
      .slice(1)
      .map((o) => Number(o.value));
    if (JSON.stringify(current) !== JSON.stringify(ids)) {
      select.replaceChildren(new Option("–", ""));
      for (const id of ids) select.add(new Option(String(id), String(id)));
      select.value = ids.includes(Number(keep)) ? keep : "";
    }
  }
  function resetForm() {
    $("request-form").reset();
    state.selectedHub = null;
    state.selectedTarget = null;
    state.selections = { collective: null, target: null };
    note("");
    if (state.view) drawMap(state.view);
  }
  async function commit(event) {
    event.preventDefault();
    if (state.committing) return;
    const kind = $("request-kind").value,
      collective = $("request-collective").value;
    const target = $("request-target").value;
    if (!kind || collective === "" || target === "") {
      note("Choose a type, a collective and a target.");
      return;
    }
    // Clicks that filled the form are part of this request, not observations.
    const selections = [];
    for (const [slot, value] of [
      ["collective", collective],
      ["target", target],
    ]) {
      const s = state.selections[slot];
      if (s && s.id !== null && s.value === value) selections.push(s.id);
    }
    // One request per press: the button stays disabled until the answer is in.
    state.committing = true;
    $("commit").disabled = true;
    note("Sending…");
    try {
      const outcome = await post("/requests", {
        kind,
        collective: Number(collective),
        target: Number(target),
        selections,
      });
      if (outcome.accepted) resetForm();
      note(
        outcome.accepted ? `Request ${outcome.request_id} accepted.` : `Refused: ${outcome.reason}`,
        outcome.accepted,
      );
    } catch (e) {
      note(e.message);
    } finally {
      state.committing = false;
      $("commit").disabled = state.ended || state.paused;
    }
  }

  // ---- Collective Assignments ------------------------------------------------
  function drawAssignments(view) {
    const list = $("assignments");
    if (!view.requests.some((r) => r.id === state.selectedAssignment)) state.selectedAssignment = null;
    // Rebuild only on change, so a click on a row is never lost to a redraw.
    const key = JSON.stringify([view.requests, state.selectedAssignment]);
    if (key === state.assignmentsKey) return;
    state.assignmentsKey = key;
    const active = document.activeElement;
    const focused = active && active.parentElement === list ? active.dataset.request : null;
    list.replaceChildren();
    for (const r of view.requests) {
      const li = document.createElement("li");
      li.dataset.request = r.id;
      li.dataset.kind = r.kind;
      if (r.id === state.selectedAssignment) li.classList.add("selected");
      const dot = document.createElement("span");
      dot.className = `dot ${r.status}`;
      dot.title = r.status.replace("_", " ");
      const label = document.createElement("span");
      label.textContent = `${r.kind} · ${NAMES[r.collective]} → target ${r.target}`;
      li.append(dot, label);
      li.tabIndex = 0;
      li.setAttribute("role", "option");
      li.setAttribute("aria-selected", r.id === state.selectedAssignment ? "true" : "false");
      li.setAttribute(
        "aria-label",
        `${r.kind}, collective ${NAMES[r.collective]}, target ${r.target}, ${r.status.replace("_", " ")}`,
      );
      const select = () => {
        state.selectedAssignment = r.id;
        drawAssignments(state.view || view);
      };
      li.addEventListener("click", select);
      li.addEventListener("keydown", (e) => {
        if (e.key === "Enter" || e.key === " ") {
          e.preventDefault();
          select();
        }
      });
      list.appendChild(li);
    }
    // A rebuild must not throw the keyboard user's focus away.
    if (focused !== null) {
      const again = list.querySelector(`li[data-request="${focused}"]`);
      if (again) again.focus();
    }
    const selected = view.requests.find((r) => r.id === state.selectedAssignment);
    $("cancel-assignment").disabled = !(selected && selected.kind === "abandon");
  }
  function cancelAssignment() {
    if (state.selectedAssignment === null) return;
    const request_id = state.selectedAssignment;
    return inFlight([$("cancel-assignment")], async () => {
      const outcome = await post("/requests", { kind: "cancel", request_id });
      note(outcome.accepted ? "Assignment cancelled." : `Refused: ${outcome.reason}`, outcome.accepted);
    });
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
  function drawProbe(probe, clockS) {
    const box = $("probe");
    // The countdown moves with every frame; the rest only when the probe changes.
    if (probe) $("probe-countdown").textContent = clock(probe.timeout_s - clockS);
    const key = probe ? [probe.id, probe.phase, probe.replay ? probe.replay.note : ""].join(":") : null;
    if (key === state.probeKey) return;
    state.probeKey = key;
    box.hidden = !probe;
    if (!probe) {
      state.probePlace = null;
      return;
    }
    box.dataset.probe = probe.id;
    $("probe-hint").textContent = "";
    box.querySelector(".probe-ready").hidden = probe.phase !== "ready";
    box.querySelector(".probe-question").hidden = probe.phase !== "question";
    if (probe.phase === "question") {
      $("probe-text").textContent = probe.question;
      const choices = $("probe-choices");
      choices.replaceChildren();
      for (const choice of probe.choices) {
        const button = document.createElement("button");
        button.type = "button";
        button.textContent = choice;
        button.dataset.answer = choice;
        button.addEventListener("click", () => answerProbe(probe.id, choice));
        if (probe.replay) {
          // the replay marks what was chosen and what was true
          button.disabled = true;
          button.classList.toggle("chosen", choice === probe.replay.answer);
          button.classList.toggle("truth", choice === probe.replay.truth);
        }
        choices.appendChild(button);
      }
      // No choice is focused or chosen for the participant: a key pressed for
      // Ready (a double press) must not answer a question that was never read.
      // Focus goes to the question itself, and keys are ignored for a moment.
      state.questionShownAt = performance.now();
      placeProbe(probe.subject);
      if (!replaying) $("probe-text").focus();
    } else {
      placeProbe(null);
      if (!replaying) $("probe-ready").focus(); // a question is waiting: Enter or Space answers "Ready"
    }
    $("probe-ready").disabled = replaying;
    $("probe-replay").hidden = !probe.replay;
    $("probe-replay").textContent = probe.replay ? probe.replay.note : "";
  }
  // The probe box overlays the map (SPAM) but must not hide what it asks about,
  // and had better hide no hub at all: of a grid of places in the map panel it
  // takes the one whose overlap with the glyphs, weighted, is least. The asked
  // collective or target weighs most, any hub (and the zoom buttons) next, any
  // other target least.
  // It stays where it is unless another place is strictly better, so it moves
  // only when the question shows (it is taller then) or the window changes.
  const PROBE_MARGIN = 12,
    PROBE_GRID = 7;
  function placeProbe(subject) {
    const box = $("probe");
    if (box.hidden) return;
    if (subject !== undefined) state.probePlace = { subject };
    const asked = state.probePlace ? state.probePlace.subject : null;
    const area = box.parentElement.getBoundingClientRect();
    const width = box.offsetWidth,
      height = box.offsetHeight;
    const obstacles = [];
    for (const g of document.querySelectorAll("#layer-collectives g.collective")) {
      const mine = asked && asked.collective === Number(g.dataset.collective);
      obstacles.push([g.getBoundingClientRect(), mine ? 1e6 : 1e3]);
    }
    for (const g of document.querySelectorAll("#layer-targets g.target")) {
      const mine = asked && asked.target === Number(g.dataset.target);
      obstacles.push([g.getBoundingClientRect(), mine ? 1e6 : 1]);
    }
    // The zoom buttons sit on the map too: hiding them weighs as much as a hub.
    const zoom = $("map-zoom");
    if (zoom && !zoom.hidden) obstacles.push([zoom.getBoundingClientRect(), 1e3]);
    const cost = (left, top) => {
      let sum = 0;
      for (const [r, weight] of obstacles) {
        const x = Math.min(area.left + left + width, r.right) - Math.max(area.left + left, r.left);
        const y = Math.min(area.top + top + height, r.bottom) - Math.max(area.top + top, r.top);
        if (x > 0 && y > 0) sum += weight * x * y;
      }
      return sum;
    };
    const spanX = Math.max(0, area.width - width - 2 * PROBE_MARGIN);
    const spanY = Math.max(0, area.height - height - 2 * PROBE_MARGIN);
    let best = null;
    if (box.style.left) {
      const left = parseFloat(box.style.left),
        top = parseFloat(box.style.top);
      if (left + width <= area.width && top + height <= area.height) best = [cost(left, top), left, top];
    }
    for (let j = 0; j < PROBE_GRID; j++) {
      for (let i = 0; i < PROBE_GRID; i++) {
        const left = PROBE_MARGIN + (spanX * i) / (PROBE_GRID - 1);
        const top = PROBE_MARGIN + (spanY * j) / (PROBE_GRID - 1);
        const c = cost(left, top);
        if (best === null || c < best[0]) best = [c, left, top];
      }
    }
    box.style.left = `${best[1]}px`;
    box.style.top = `${best[2]}px`;
  }
  // Keys in the probe box within this time of its question showing are ignored, and the
  // box says so: a key that did nothing without a word looked like a broken page.
  const PROBE_KEY_GUARD_MS = 500;
  function guardProbeKeys(e) {
    if (state.questionShownAt === undefined || $("probe").hidden) return;
    if (e.key !== "Enter" && e.key !== " ") return;
    if (performance.now() - state.questionShownAt < PROBE_KEY_GUARD_MS) {
      e.preventDefault();
      e.stopPropagation();
      $("probe-hint").textContent = "Read the question first, then choose an answer.";
    } else if (e.target === $("probe-text")) {
      $("probe-hint").textContent = "Choose an answer: click it, or Tab to it and press Enter.";
    }
  }
  function readyProbe() {
    const id = Number($("probe").dataset.probe);
    return inFlight([$("probe-ready")], () => post(`/probes/${id}/ready`));
  }
  function answerProbe(id, answer) {
    const buttons = Array.from($("probe-choices").querySelectorAll("button"));
    return inFlight(buttons, async () => {
      await post(`/probes/${id}/answer`, { answer });
      // A frame may already show the next probe (the server closed this one when it
      // committed, before this reply arrived): only the answered probe's box is hidden.
      if (Number($("probe").dataset.probe) === id) $("probe").hidden = true;
    });
  }

  // ---- the stream ---------------------------------------------------------------
  function showPause(paused) {
    if (paused === state.paused) return;
    state.paused = paused;
    $("paused").hidden = !paused;
    $("clock-box").classList.toggle("paused", paused);
    $("clock-state").textContent = paused ? "paused" : "";
    $("commit").disabled = paused || state.ended || state.committing;
  }
  // A page whose first frame is late says so, rather than show a blank map and a stopped clock.
  const CONNECTING_NOTICE_MS = 1000;
  let connectingTimer = null;
  function onFrame(frame) {
    if (connectingTimer !== null) {
      clearTimeout(connectingTimer);
      connectingTimer = null;
    }
    $("connecting").hidden = true;
    // After a takeover the new host resumes from its newest row, which may be a little
    // behind what this page showed: hold the clock and the map until it catches up.
    const behind = frame.trial.status !== "ended" && frame.trial.clock_s < state.shownClockS;
    if (!behind) {
      state.shownClockS = frame.trial.clock_s;
      $("clock").textContent = clock(frame.trial.clock_s);
    }
    showPause(frame.trial.status === "paused");
    if (frame.messages) addMessages(frame.messages);
    if (frame.view && !behind) {
      state.view = frame.view;
      refreshCollectiveOptions(frame.view);
      refreshTargetOptions();
      drawMap(frame.view);
      drawAssignments(frame.view);
    }
    drawProbe(frame.probe || null, frame.trial.clock_s);
    if (frame.trial.status === "ended") endTrial(frame.trial.end_reason);
  }
  // Why the trial ended, in the participant's words; the time limit is the usual reason.
  const ENDINGS = {
    aborted: [
      "Ended by the experimenter",
      "The experimenter has ended this session. Please wait for their instructions.",
    ],
  };
  function endTrial(reason) {
    const ending = ENDINGS[reason];
    if (ending) {
      $("ended-title").textContent = ending[0];
      $("ended-text").textContent = ending[1];
      $("clock-box").hidden = true; // the clock stopped early; its time is not the limit
    }
    state.ended = true;
    if (stream) stream.close();
    $("probe").hidden = true;
    $("ended").hidden = false;
    $("commit").disabled = true;
    $("connection").textContent = "trial over";
    const next = root.dataset.continueUrl;
    if (next) {
      $("continue").href = next;
      $("continue").hidden = false;
    }
  }

  // Another tab or window opened the same trial: the server tells this one
  // ("takeover" event) and ends its stream; it must not reconnect and run twice.
  function takenOver() {
    state.ended = true;
    if (stream) stream.close();
    $("probe").hidden = true;
    $("paused").hidden = true;
    $("taken-over").hidden = false;
    $("commit").disabled = true;
    $("connection").textContent = "opened elsewhere";
    $("connection").className = "connection";
  }

  let stream = null;
  let lastEventId = ""; // the newest System Message shown; a new stream resumes after it
  function streamUrl() {
    const url = new URL(root.dataset.streamUrl, window.location.href);
    if (lastEventId) url.searchParams.set("after", lastEventId);
    return url.toString();
  }
  // The watchdog: a host that hangs (stopped, or cut off from its database) keeps the
  // connection open and sends nothing, and EventSource waits forever. Frames come several
  // times a second, so an open stream silent for STALLED_MS is dropped and opened again;
  // the proxy sends the new one on to a process that answers. A new stream is given
  // OPENING_MS: the proxy waits out its own read timeout at the silent process before it
  // passes the stream on, and the next process may first wait out the silent one's lease
  // and rebuild the trial. Dropping it sooner sends it back to the silent process.
  const STALLED_MS = 3000,
    OPENING_MS = 12000;
  let lastFrameAt = Date.now();
  setInterval(() => {
    if (state.ended || !stream || stream.readyState === EventSource.CLOSED) return;
    const limitMs = stream.readyState === EventSource.OPEN ? STALLED_MS : OPENING_MS;
    if (Date.now() - lastFrameAt < limitMs) return;
    $("connection").textContent = "reconnecting…";
    $("connection").className = "connection";
    stream.close();
    connect();
  }, 500);
  function connect() {
    lastFrameAt = Date.now();
    stream = new EventSource(streamUrl());
    stream.onopen = () => {
      lastFrameAt = Date.now();
      $("connection").textContent = "live";
      $("connection").className = "connection ok";
    };
    stream.onerror = () => {
      if (state.ended) return;
      $("connection").textContent = "reconnecting…";
      $("connection").className = "connection";
      if (stream.readyState === EventSource.CLOSED) retryLater(stream);
    };
    stream.onmessage = (event) => {
      lastFrameAt = Date.now();
      if (event.lastEventId) lastEventId = event.lastEventId;
      onFrame(JSON.parse(event.data));
    };
    stream.addEventListener("takeover", takenOver);
  }
  // EventSource retries by itself only when the connection drops. An answer
  // other than 200 (a 503 when the server holds as many streams as it can)
  // closes it for good, and it cannot read the answer's headers. So ask again
  // with HEAD, which the server answers like the stream without opening one,
  // wait as long as its Retry-After says (plus up to half again, so refused
  // pages do not all come back at once), and open a new stream.
  const RETRY_DEFAULT_S = 5,
    RETRY_MAX_S = 60,
    PROXY_RETRY_S = 1;
  function retryAfterS(response) {
    const seconds = Number(response.headers.get("Retry-After"));
    return Number.isFinite(seconds) && seconds > 0 ? Math.min(seconds, RETRY_MAX_S) : RETRY_DEFAULT_S;
  }
  async function retryLater(closed) {
    let waitS = RETRY_DEFAULT_S;
    try {
      const response = await fetch(streamUrl(), { method: "HEAD", cache: "no-store", credentials: "same-origin" });
      if (response.ok) waitS = 0;
      else if (response.status === 503 || response.status === 429) waitS = retryAfterS(response);
      // The proxy's own answer: the process it tried first did not answer in time (a
      // stopped host) or at all. Another may host the trial by now: ask again soon.
      else if (response.status === 502 || response.status === 504) waitS = PROXY_RETRY_S;
      else if (response.status < 500) {
        // the link or the trial is gone: a reload says why
        $("connection").textContent = "disconnected: reload the page";
        return;
      }
    } catch (_error) {
      /* the server is away: try again after the default wait */
    }
    const delayMs = waitS * 1000 * (1 + (waitS ? Math.random() / 2 : 0));
    setTimeout(() => {
      if (!state.ended && stream === closed) connect();
    }, delayMs);
  }

  document.addEventListener("keydown", (e) => {
    if (e.key === "Escape" && state.flag) {
      e.preventDefault();
      closeFlag();
    }
  });
  const fullscreen = $("fullscreen");
  if (document.fullscreenEnabled) {
    fullscreen.hidden = false;
    fullscreen.addEventListener("click", () => {
      if (document.fullscreenElement) document.exitFullscreen();
      else document.documentElement.requestFullscreen().catch(() => note("Full screen is not available here."));
    });
    document.addEventListener("fullscreenchange", () => {
      fullscreen.textContent = document.fullscreenElement ? "Leave full screen" : "Full screen";
    });
  }

  $("request-form").addEventListener("submit", commit);
  $("request-reset").addEventListener("click", resetForm);
  $("cancel-assignment").addEventListener("click", cancelAssignment);
  $("probe-ready").addEventListener("click", readyProbe);
  $("probe").addEventListener("keydown", guardProbeKeys, true);
  $("map").addEventListener("contextmenu", (e) => e.preventDefault());
  $("request-collective").addEventListener("change", (e) => {
    state.selectedHub = e.target.value === "" ? null : Number(e.target.value);
    if (state.view) drawMap(state.view);
  });
  $("request-target").addEventListener("change", (e) => {
    state.selectedTarget = e.target.value === "" ? null : Number(e.target.value);
    if (state.view) drawMap(state.view);
  });
  $("zoom-in").addEventListener("click", () => zoomBy(ZOOM_STEP));
  $("zoom-out").addEventListener("click", () => zoomBy(1 / ZOOM_STEP));
  $("zoom-reset").addEventListener("click", resetZoom);
  $("map").addEventListener(
    "wheel",
    (e) => {
      e.preventDefault();
      zoomBy(e.deltaY < 0 ? ZOOM_STEP : 1 / ZOOM_STEP, e.clientX, e.clientY);
    },
    { passive: false },
  );
  $("map").addEventListener("pointerdown", startDrag);
  $("map").addEventListener("pointermove", moveDrag);
  $("map").addEventListener("pointerup", endDrag);
  $("map").addEventListener("pointercancel", endDrag);
  $("map-zoom").addEventListener("keydown", mapKeys);
  $("map").addEventListener("keydown", mapKeys);
  fitMap();
  new ResizeObserver(fitMap).observe($("map"));
  if (replaying) {
    const clearMessages = () => {
      $("messages").replaceChildren();
      state.seenMessages.clear();
    };
    window.hcssInterface = { onFrame, clearMessages };
  } else {
    if (root.dataset.status === "ended") endTrial();
    else
      connectingTimer = setTimeout(() => {
        $("connecting").hidden = false;
      }, CONNECTING_NOTICE_MS);
    connect();
  }
})();
