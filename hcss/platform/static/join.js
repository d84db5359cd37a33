// The study link's first page (templates/study/join.html): measures the window,
// the device and the browser's features, and posts them with Start. A device
// that can never run the study (a phone, a browser without the features) is
// sent on at once, to the page with the screen-out code; a window that is only
// too small can be enlarged first. The server decides from what is posted.
// In a frame (MTurk shows a HIT in one) the study opens in its own window instead:
// the server says so when the browser tells it (Sec-Fetch-Dest), this when not.
(() => {
  "use strict";
  const box = document.getElementById("device-check");
  if (window.self !== window.top || !box) {
    const offer = document.getElementById("join-framed");
    const finished = document.getElementById("join-finished");
    const intro = document.getElementById("join-intro");
    if (intro) intro.hidden = true; // the frame checks nothing: no words about a check
    const form = document.getElementById("join-form");
    if (form) form.hidden = true; // left out by the server when it knew of the frame
    if (box) box.hidden = true;
    if (!finished.hidden) return;
    offer.hidden = false;
    // Once the study runs in its own window, ask now and then whether it is done, and
    // stop offering it then (the worker comes back to this frame after submitting).
    let asking = null;
    const ask = () =>
      fetch(offer.dataset.statusUrl, { credentials: "omit" })
        .then((answer) => (answer.ok ? answer.json() : {}))
        .then((status) => {
          if (!status.finished) return;
          offer.hidden = true;
          finished.hidden = false;
          clearInterval(asking);
        })
        .catch(() => {});
    document.getElementById("join-own-window").addEventListener("click", () => {
      if (asking === null) asking = setInterval(ask, 3000);
    });
    return;
  }
  const minW = Number(box.dataset.minWidth),
    minH = Number(box.dataset.minHeight);
  const desktopOnly = box.dataset.desktopOnly === "true";
  const wanted = box.dataset.features.split(",").filter(Boolean);
  const has = {
    eventsource: "EventSource" in window,
    fetch: "fetch" in window,
    svg: !!document.createElementNS?.("http://www.w3.org/2000/svg", "svg").createSVGRect,
    crypto: !!(window.crypto && crypto.getRandomValues),
  };
  const missing = wanted.filter((name) => !has[name]);
  const agentMobile = navigator.userAgentData
    ? navigator.userAgentData.mobile
    : /Mobi|Android|iPhone|iPad|iPod/i.test(navigator.userAgent);
  const touchOnly = matchMedia("(pointer: coarse)").matches && !matchMedia("(any-pointer: fine)").matches;
  const mobile = agentMobile || touchOnly;
  const form = document.getElementById("join-form");
  const field = (id, value) => {
    document.getElementById(id).value = value;
  };
  field("join-mobile", mobile ? "1" : "0");
  field("join-missing", missing.join(","));
  function check() {
    const w = window.innerWidth,
      h = window.innerHeight,
      big = w >= minW && h >= minH;
    field("join-width", w);
    field("join-height", h);
    document.getElementById("window-size").textContent = `${w} x ${h}`;
    document.getElementById("window-too-small").hidden = big;
    document.getElementById("join-cannot").hidden = big;
    document.getElementById("device-ok").hidden = !big;
    document.getElementById("join-start").disabled = !big;
  }
  check();
  if ((desktopOnly && mobile) || missing.length) {
    form.submit();
    return;
  }
  // Maximising, full screen and zooming out all fire resize (zoom changes the CSS pixels).
  window.addEventListener("resize", check);
})();
