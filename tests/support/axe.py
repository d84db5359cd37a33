"""axe-core in the browser tests: WCAG 2.1 A and AA checks of the page a test has open.

axe-core is the npm package that package.json pins; `make test` installs it
with scripts/ensure-node-tools (into node_modules/, git-ignored). Each check
evaluates axe.min.js in the page (through the DevTools protocol) and runs it
with the WCAG 2.1 A/AA tags only, so a rule axe adds in a later release for
best practice does not fail the suite, and a regression of the pages does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

AXE_SCRIPT = Path(__file__).resolve().parents[2] / "node_modules" / "axe-core" / "axe.min.js"
#: The rules run: WCAG 2.0 and 2.1, levels A and AA.
WCAG_TAGS = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa"]

_RUN = """async (tags) => {
  const result = await axe.run(document, {runOnly: {type: "tag", values: tags},
                                          resultTypes: ["violations"]});
  return result.violations.map((v) => ({
    id: v.id, impact: v.impact,
    nodes: v.nodes.map((n) => ({target: n.target.join(" "), summary: n.failureSummary})),
  }));
}"""


def axe_violations(page: Any) -> list[dict[str, Any]]:
    """The page's WCAG 2.1 A/AA violations as axe-core reports them: id, impact, nodes.

    `page` may be a frame on another site than its page (MTurk's HIT frame): Chromium
    runs it in its own process, which a DevTools session of its own reaches."""
    if not AXE_SCRIPT.exists():
        pytest.fail(
            f"{AXE_SCRIPT} is missing: run `bash scripts/ensure-node-tools` (make test does)"
        )
    if not page.evaluate("() => typeof window.axe !== 'undefined'"):
        # Through the DevTools protocol: the pages' Content-Security-Policy refuses an
        # injected <script> (add_script_tag), and a test must not switch it off to look.
        owner = getattr(page, "page", page)  # a Frame's page, else the page itself
        devtools = owner.context.new_cdp_session(page)
        devtools.send("Runtime.evaluate", {"expression": AXE_SCRIPT.read_text()})
        devtools.detach()
    return page.evaluate(_RUN, WCAG_TAGS)


def summary(violations: list[dict[str, Any]]) -> str:
    """One line per rule: its id, impact, node count and the first nodes' selectors."""
    return "; ".join(
        f"{v['id']} ({v['impact']}, {len(v['nodes'])} nodes: "
        + ", ".join(n["target"] for n in v["nodes"][:3])
        + "; first: "
        + " ".join(v["nodes"][0]["summary"].split())[:160]
        + ")"
        for v in violations
    )


def node_count(violations: list[dict[str, Any]]) -> int:
    return sum(len(v["nodes"]) for v in violations)
