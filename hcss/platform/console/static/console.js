// The live participant table: refreshed every two seconds (CONSOLE_POLL_S) from /console/progress.json,
// one page at a time, with filters that hide pilot, bot and demo participants (remembered in this
// browser; the server filters, so a page is full).
(() => {
  "use strict";
  // A button that asks first (Abort): one delegated handler, since inline script is forbidden (CSP).
  document.addEventListener("click", (event) => {
    const button = event.target.closest?.("button[data-confirm]");
    if (button && !window.confirm(button.dataset.confirm)) event.preventDefault();
  });
  const table = document.getElementById("progress");
  if (!table) return;
  const body = table.querySelector("tbody");
  const labels = JSON.parse(table.dataset.labels);
  const csrf = document.querySelector('meta[name="csrf-token"]').content;
  const filters = Array.from(document.querySelectorAll("#filters input[data-flag]"));
  const shownCount = document.getElementById("shown-count");
  const COLUMNS = 10;
  const search = document.getElementById("search");
  // The search's words, marked where they appear in a cell (the server found the rows).
  function marked(text) {
    const words = (search ? search.value : "")
      .trim()
      .split(/\s+/)
      .filter(Boolean)
      .map((word) => word.replace(/[.*+?^${}()|[\]\\]/g, "\\$&"));
    const span = document.createElement("span");
    if (!words.length) {
      span.textContent = text;
      return span;
    }
    text.split(new RegExp(`(${words.join("|")})`, "i")).forEach((piece, index) => {
      if (index % 2) {
        const mark = document.createElement("mark");
        mark.textContent = piece;
        span.append(mark);
      } else if (piece) {
        span.append(piece);
      }
    });
    return span;
  }
  const minutes = (s) => `${Math.floor(s / 60)}:${String(Math.floor(s % 60)).padStart(2, "0")}`;

  function cell(text, className) {
    const td = document.createElement("td");
    td.textContent = text;
    if (className) td.className = className;
    return td;
  }

  function stageCell(p) {
    const td = cell("", "stage");
    if (p.stage_number !== null) {
      const of = document.createElement("span");
      of.className = "stage-of";
      of.textContent = `stage ${p.stage_number} of ${p.stage_count}`;
      const bar = document.createElement("progress");
      bar.max = p.stage_count;
      bar.value = p.status === "completed" ? p.stage_count : p.stage_number - 1;
      td.append(of, " ", bar, " ");
    }
    const name = document.createElement("span");
    name.className = "stage-name";
    name.textContent = p.stage;
    td.append(name);
    return td;
  }

  function presenceCell(p) {
    const td = cell(
      p.connected ? "connected" : "disconnected",
      `presence ${p.connected ? "connected" : "disconnected"}`,
    );
    if (p.connected && p.page_hidden) td.append(" (tab hidden)");
    const seen = document.createElement("span");
    seen.className = "muted";
    seen.textContent = p.last_seen_s === null ? "never seen" : `seen ${Math.floor(p.last_seen_s)} s ago`;
    td.append(" ", seen);
    return td;
  }

  function actionsCell(p) {
    const td = cell("", "row-actions");
    for (const action of p.actions) {
      const form = document.createElement("form");
      form.method = "post";
      form.className = "inline";
      form.action = table.dataset.actionUrl.replace("CODE", encodeURIComponent(p.code)).replace("ACTION", action);
      for (const [name, value] of [
        ["csrf_token", csrf],
        ["next", table.dataset.indexUrl],
      ]) {
        const input = document.createElement("input");
        input.type = "hidden";
        input.name = name;
        input.value = value;
        form.append(input);
      }
      const button = document.createElement("button");
      button.type = "submit";
      button.dataset.action = action;
      button.textContent = labels[action];
      if (action === "abort") button.dataset.confirm = "Abort this session?";
      if (action === "skip_stage") button.dataset.confirm = "Move this participant past their current step?";
      form.append(button);
      td.append(form);
    }
    return td;
  }

  function row(p) {
    const tr = document.createElement("tr");
    tr.dataset.code = p.code;
    tr.dataset.pilot = p.is_pilot ? "1" : "0";
    tr.dataset.bot = p.is_bot ? "1" : "0";
    tr.dataset.demo = p.is_demo ? "1" : "0";
    const link = document.createElement("a");
    link.href = table.dataset.participantUrl.replace("CODE", encodeURIComponent(p.code));
    link.append(...marked(p.code).childNodes);
    const first = document.createElement("td");
    first.append(link);
    if (p.recruitment) {
      const id = document.createElement("span");
      id.className = "recruitment muted";
      id.append(...marked(p.recruitment).childNodes);
      first.append(id);
    }
    const shown =
      p.status === "not_enrolled" && p.state === "active"
        ? "not started"
        : p.status === "completed" || p.status === "declined"
          ? p.status
          : p.state;
    const clock =
      p.trial_clock_s === null ? "–" : `${minutes(p.trial_clock_s)} / ${Math.floor(p.trial_duration_s / 60)} min`;
    const flags = [p.is_pilot && "pilot", p.is_bot && "bot", p.is_demo && "demo"].filter(Boolean);
    // The row's checkbox belongs to the bulk form above the table (its form attribute).
    const select = document.createElement("input");
    select.type = "checkbox";
    select.name = "codes";
    select.value = p.code;
    select.className = "select";
    select.setAttribute("form", "bulk-form");
    select.setAttribute("aria-label", `Select ${p.code}`);
    const pick = document.createElement("td");
    pick.append(select);
    tr.append(
      pick,
      first,
      cell(`${p.study} · ${p.cell === null ? "cell at first visit" : `cell ${p.cell}`}`, "study"),
      (() => {
        const td = cell("", `session state-${shown}`);
        td.append(...marked(shown).childNodes);
        return td;
      })(),
      stageCell(p),
      cell(p.time_in_stage_s === null ? "–" : minutes(p.time_in_stage_s)),
      cell(clock),
      presenceCell(p),
      cell(flags.join(" ")),
      actionsCell(p),
    );
    return tr;
  }

  // The search box asks the server, which looks through every participant (code, recruitment
  // or session id, status): "N of everyone" are the participants it found.
  // Participants before any filter, and those found, as the server last counted them.
  let everyone = null;
  let found = null;
  function applyFilters() {
    const hidden = filters.filter((box) => box.checked).map((box) => box.dataset.flag);
    for (const tr of body.querySelectorAll("tr[data-code]")) {
      tr.hidden = hidden.some((flag) => tr.dataset[flag] === "1");
    }
    if (shownCount && everyone !== null) {
      shownCount.textContent = `showing ${found} of ${everyone}`;
    }
  }

  // Cells are replaced only where their content changed, so a button (and the click on it)
  // survives the refresh of everything around it.
  function sync(tr, fresh) {
    for (const flag of ["pilot", "bot", "demo"]) tr.dataset[flag] = fresh.dataset[flag];
    const old = Array.from(tr.children);
    const now = Array.from(fresh.children);
    if (old.length !== now.length) {
      tr.replaceChildren(...now);
      return;
    }
    now.forEach((td, i) => {
      if (old[i].outerHTML !== td.outerHTML) old[i].replaceWith(td);
    });
  }

  function render(participants) {
    if (pressing) return; // a click half done must not lose its button to a redraw
    const wanted = new Set(participants.map((p) => p.code));
    const existing = new Map();
    for (const tr of Array.from(body.children)) {
      if (tr.dataset.code && wanted.has(tr.dataset.code)) existing.set(tr.dataset.code, tr);
      else tr.remove();
    }
    if (participants.length === 0) {
      const tr = document.createElement("tr");
      const td = cell("No participants yet.");
      td.colSpan = COLUMNS;
      if (search?.value.trim()) td.textContent = "No participant matches the search.";
      tr.append(td);
      body.append(tr);
    }
    let previous = null;
    for (const p of participants) {
      const fresh = row(p);
      let tr = existing.get(p.code);
      if (tr) sync(tr, fresh);
      else tr = fresh;
      const place = previous ? previous.nextSibling : body.firstChild;
      if (place !== tr) body.insertBefore(tr, place);
      previous = tr;
    }
    applyFilters();
  }

  // The server pages and filters the table: ask for this page with the hidden flags.
  const pager = document.getElementById("pager");
  const pageOf = document.getElementById("page-of");
  function pageUrl() {
    const hidden = filters.filter((box) => box.checked).map((box) => box.dataset.flag);
    const page = pager ? pager.dataset.page : "1";
    return (
      table.dataset.url +
      "?page=" +
      encodeURIComponent(page) +
      "&hide=" +
      encodeURIComponent(hidden.join(",")) +
      "&q=" +
      encodeURIComponent(search ? search.value.trim() : "")
    );
  }

  async function poll() {
    try {
      const response = await fetch(pageUrl(), { credentials: "same-origin" });
      if (response.ok) {
        const answer = await response.json();
        if (typeof answer.everyone === "number") everyone = answer.everyone;
        found = answer.total;
        if (pager) pager.dataset.page = String(answer.page);
        render(answer.participants);
        if (pageOf) {
          pageOf.textContent =
            "page " +
            answer.page +
            " of " +
            answer.pages +
            " · " +
            answer.total +
            " participants" +
            (answer.search ? ` matching “${answer.search}”` : "");
        }
        pagerLinks(answer);
      }
    } catch (_error) {
      // A dropped poll is retried by the next one.
    }
  }

  let pressing = false;
  table.addEventListener("pointerdown", () => {
    pressing = true;
  });
  const released = () => {
    setTimeout(() => {
      pressing = false;
    }, 0);
  };
  for (const type of ["pointerup", "pointercancel"]) document.addEventListener(type, released);
  window.addEventListener("blur", released);

  for (const box of filters) {
    box.checked = localStorage.getItem(`hcss-hide-${box.dataset.flag}`) === "1";
    box.addEventListener("change", () => {
      localStorage.setItem(`hcss-hide-${box.dataset.flag}`, box.checked ? "1" : "0");
      applyFilters();
      poll();
    });
  }
  // Newer/older links that keep the search.
  function pagerLinks(answer) {
    for (const [id, page, label, shown] of [
      ["newer", answer.page - 1, "newer", answer.page > 1],
      ["older", answer.page + 1, "older", answer.page < answer.pages],
    ]) {
      let link = document.getElementById(id);
      if (!shown) {
        if (link) link.remove();
        continue;
      }
      if (!link) {
        link = document.createElement("a");
        link.id = id;
        link.textContent = label;
        if (id === "newer") pager.prepend(link, " ");
        else pager.append(" ", link);
      }
      const query = new URLSearchParams({ page: String(page) });
      if (answer.search) query.set("q", answer.search);
      link.href = `${table.dataset.indexUrl}?${query.toString()}`;
    }
  }
  let typing = null;
  if (search) {
    search.addEventListener("input", () => {
      clearTimeout(typing);
      typing = setTimeout(() => {
        if (pager) pager.dataset.page = "1";
        const query = new URLSearchParams(window.location.search);
        if (search.value.trim()) query.set("q", search.value.trim());
        else query.delete("q");
        query.delete("page");
        history.replaceState(null, "", `?${query.toString()}`);
        poll();
      }, 250);
    });
  }
  // Select every row of this page for the bulk form.
  const all = document.getElementById("select-all");
  if (all) {
    all.addEventListener("change", () => {
      for (const box of body.querySelectorAll("tr:not([hidden]) input.select")) {
        box.checked = all.checked;
      }
    });
  }
  applyFilters();
  poll();
  setInterval(poll, Number(table.dataset.pollMs) || 2000);
})();
