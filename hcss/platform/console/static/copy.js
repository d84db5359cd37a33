// Copy buttons of the batch links page: one link, or every link still usable one per line
// (a completed, aborted, declined or timed-out participant's link leads nowhere new).
(() => {
  "use strict";

  async function copy(text, button) {
    try {
      await navigator.clipboard.writeText(text);
    } catch (_error) {
      // No clipboard API (a plain-http lab server that is not localhost): select and copy.
      const area = document.createElement("textarea");
      area.value = text;
      document.body.append(area);
      area.select();
      document.execCommand("copy");
      area.remove();
    }
    const label = button.textContent;
    button.textContent = "Copied";
    button.classList.add("copied");
    setTimeout(() => {
      button.textContent = label;
      button.classList.remove("copied");
    }, 1500);
  }

  for (const button of document.querySelectorAll("button.copy")) {
    button.addEventListener("click", () => copy(button.dataset.copy, button));
  }
  const all = document.getElementById("copy-all");
  if (all) {
    all.addEventListener("click", () => {
      const links = Array.from(document.querySelectorAll('button.copy[data-usable="1"]'), (b) => b.dataset.copy);
      copy(links.join("\n"), all);
    });
  }
})();
