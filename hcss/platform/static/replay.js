// The replay page: plays a recorded trial's rebuilt frames through the Collective
// Interface's own drawing (live.js in replay mode, window.hcssInterface), with the
// participant's requests and probe answers marked on a timeline. No framework.
(() => {
  "use strict";
  const face = window.hcssInterface;
  const root = document.getElementById("replay");
  const $ = (id) => document.getElementById(id);
  const chunk = Number(root.dataset.chunk);
  const AHEAD_S = 60; // wall seconds of frames to keep loaded ahead of the cursor
  const state = {
    timeline: null,
    dt: 1,
    frames: [],
    horizon: 0,
    ended: false,
    digests: null,
    t: 0,
    speed: 1,
    playing: false,
    shownStep: -1,
    messagesShown: 0,
    loading: false,
    lastTick: null,
  };

  function clock(seconds) {
    const s = Math.max(0, Math.floor(seconds));
    return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
  }
  const loadedUpTo = () => state.frames.length - 1;
  const endTime = () => state.horizon * state.dt;

  // ---- loading -------------------------------------------------------------------
  async function fetchJson(url) {
    const response = await fetch(url, { credentials: "same-origin" });
    if (!response.ok) throw new Error(`${url}: ${response.status}`);
    return response.json();
  }
  async function loadMore() {
    if (state.loading) return;
    const next = state.frames.length;
    const wanted = Math.floor(state.t / state.dt) + AHEAD_S * state.speed;
    if (next > wanted || (state.ended && next > state.horizon)) return;
    state.loading = true;
    try {
      const body = await fetchJson(`${root.dataset.framesUrl}?start=${next}&count=${chunk}`);
      if (body.start === state.frames.length) state.frames.push(...body.frames);
      state.horizon = body.horizon;
      state.ended = body.ended;
      if (body.replayed_digest && loadedUpTo() === body.horizon) {
        state.digests = { replayed: body.replayed_digest, recorded: body.recorded_digest };
      }
      $("replay-buffered").style.width = `${percent(loadedUpTo() * state.dt)}%`;
      // A live trial's recording grows: look again shortly for newer snapshots.
      if (!state.ended && !body.frames.length) await new Promise((r) => setTimeout(r, 2000));
    } catch (error) {
      $("replay-verdict").textContent = error.message;
    } finally {
      state.loading = false;
    }
  }

  // ---- the timeline ----------------------------------------------------------------
  function percent(time) {
    const span = Math.max(state.timeline.trial.duration_s, endTime(), 1);
    return Math.min(100, (100 * time) / span);
  }
  function drawMarks() {
    const marks = $("replay-marks");
    marks.replaceChildren();
    const add = (time, className, title) => {
      const mark = document.createElement("span");
      mark.className = `mark ${className}`;
      mark.style.left = `${percent(time)}%`;
      mark.title = `${clock(time)} ${title}`;
      mark.addEventListener("click", (e) => {
        e.stopPropagation();
        seek(time);
      });
      marks.appendChild(mark);
    };
    for (const c of state.timeline.commands) {
      const refused = c.accepted === false;
      add(c.time, refused ? "refused" : "accepted", c.label + (refused ? ` (refused: ${c.reason})` : ""));
    }
    for (const p of state.timeline.probes) {
      const verdict = p.correct === true ? "correct" : p.correct === false ? "wrong" : "missed";
      const answer = p.timed_out ? "timed out" : `answered ${p.answer}`;
      add(
        p.shown,
        `probe-mark ${verdict}`,
        `probe ${p.index} (level ${p.level}): ${p.question} ${answer}; truth ${p.truth ?? "?"}`,
      );
    }
  }
  // The probe on screen at time t, in the live page's own shape, so the Collective
  // Interface draws it in its own box, where the participant saw it. It stays a
  // moment after it closed, so an answer given at once can be seen.
  const PROBE_HOLD_S = 2;
  function probeAt(t) {
    const p = state.timeline.probes.find((x) => x.shown <= t && t < x.closed + PROBE_HOLD_S);
    if (!p) return null;
    const asked = p.ready !== null && t >= p.ready;
    const verdict = p.correct === null ? "not scored" : p.correct ? "right" : "wrong";
    const note = p.timed_out
      ? asked
        ? `Ready at ${clock(p.ready)}; no answer: timed out at ${clock(p.closed)}.`
        : `Ready was not pressed: timed out at ${clock(p.closed)}.`
      : `Answered ${p.answer} at ${clock(p.closed)}: ${verdict} (truth ${p.truth ?? "not yet known"}).`;
    return {
      id: p.index,
      index: p.index,
      level: p.level,
      phase: asked ? "question" : "ready",
      question: asked ? p.question : null,
      choices: asked ? p.choices : null,
      subject: asked ? p.subject : null,
      timeout_s: p.timeout,
      replay: { answer: p.answer, truth: p.truth, note },
    };
  }
  function showCommands(t) {
    const list = $("replay-commands");
    const done = state.timeline.commands.filter((c) => c.time <= t);
    if (list.dataset.count === String(done.length)) return;
    list.dataset.count = String(done.length);
    list.replaceChildren();
    for (const c of done.slice(-12).reverse()) {
      const li = document.createElement("li");
      li.className = c.accepted === false ? "refused" : "accepted";
      const time = document.createElement("time");
      time.textContent = clock(c.time);
      li.append(time, document.createTextNode(c.label + (c.accepted === false ? ` — refused: ${c.reason}` : "")));
      list.appendChild(li);
    }
  }

  // ---- playing ---------------------------------------------------------------------
  function render() {
    const step = Math.min(Math.floor(state.t / state.dt + 1e-9), loadedUpTo());
    if (step < 0) return;
    const messages = state.timeline.messages;
    const fresh = [];
    while (state.messagesShown < messages.length && messages[state.messagesShown].time <= state.t) {
      fresh.push(messages[state.messagesShown]);
      state.messagesShown += 1;
    }
    const frame = {
      trial: { clock_s: state.t, status: "running", step, duration_s: state.timeline.trial.duration_s },
      messages: fresh,
      probe: probeAt(state.t),
    };
    if (step !== state.shownStep) {
      frame.view = state.frames[step];
      state.shownStep = step;
    }
    face.onFrame(frame);
    root.dataset.step = String(step);
    $("replay-clock").textContent = `${clock(state.t)} / ${clock(endTime())}`;
    $("replay-cursor").style.left = `${percent(state.t)}%`;
    showCommands(state.t);
  }
  function seek(time) {
    const target = Math.max(0, Math.min(time, endTime(), loadedUpTo() * state.dt));
    if (target < state.t) {
      face.clearMessages();
      state.messagesShown = 0;
    }
    state.t = target;
    render();
  }
  function finish() {
    state.playing = false;
    if (!state.ended) {
      $("replay-play").textContent = "Play on";
      root.dataset.state = "caught-up";
      return;
    }
    $("replay-play").textContent = "Play again";
    root.dataset.state = "ended";
    const digests = state.digests;
    if (!digests) return;
    root.dataset.endDigest = digests.replayed;
    const same = digests.recorded && digests.recorded === digests.replayed;
    $("replay-verdict").className = `verdict ${same ? "same" : "different"}`;
    $("replay-verdict").textContent = digests.recorded
      ? (same ? "End state identical to the recording" : "End state differs from the recording") +
        ` (digest ${digests.replayed.slice(0, 12)}…)`
      : `End state digest ${digests.replayed.slice(0, 12)}… (no recorded end snapshot)`;
  }
  function tick(now) {
    if (state.playing && state.lastTick !== null) {
      const wanted = state.t + ((now - state.lastTick) / 1000) * state.speed;
      state.t = Math.min(wanted, loadedUpTo() * state.dt, endTime()); // waits while loading
      render();
      if (state.t >= endTime() && loadedUpTo() >= state.horizon && !state.loading) finish();
    }
    state.lastTick = now;
    loadMore();
    requestAnimationFrame(tick);
  }

  function play() {
    if (state.playing) {
      state.playing = false;
      root.dataset.state = "paused";
      $("replay-play").textContent = "Play";
      return;
    }
    // An ended trial played to its end starts again; a live one goes on as its recording grows.
    if (state.ended && state.t >= endTime()) seek(0);
    state.playing = true;
    root.dataset.state = "playing";
    $("replay-play").textContent = "Pause";
  }

  async function start() {
    const requests = document.querySelector("section.requests");
    const list = document.createElement("ol");
    list.id = "replay-commands";
    list.className = "message-list replay-commands";
    requests.querySelector("h2").textContent = "Collective Requests (the participant's)";
    requests.appendChild(list);
    $("connection").textContent = "replay";
    state.timeline = await fetchJson(root.dataset.timelineUrl);
    state.dt = state.timeline.trial.dt;
    await loadMore();
    drawMarks();
    render();
    $("replay-play").disabled = false;
    $("replay-play").addEventListener("click", play);
    $("replay-speed").addEventListener("change", (e) => {
      state.speed = Number(e.target.value);
    });
    $("replay-track").addEventListener("click", (e) => {
      const box = e.currentTarget.getBoundingClientRect();
      const span = Math.max(state.timeline.trial.duration_s, endTime(), 1);
      seek(((e.clientX - box.left) / box.width) * span);
    });
    root.dataset.state = "ready";
    requestAnimationFrame(tick);
  }
  start();
})();
