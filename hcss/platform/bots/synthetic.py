"""The synthetic operator as a participant bot: the page's own protocol over HTTP.

The same `SyntheticOperator` that runs in process (`hcss.experiments.synthetic_trials`)
supervises a live trial here through what a participant's page uses:

- it reads the interface from the trial's event stream, opened with
  ``?after=`` the last message id it saw (as `live.js` reconnects), one frame
  per look, and builds the `Display` from the frame's view (`Display.from_json`);
- every command (requests, observation clicks, probe ready and answer) carries
  a fresh Idempotency-Key, and a 502, 503 or 504 is sent again with the same
  key after a short wait, doubling up to the answer's Retry-After, as `live.js`
  does: the server carries a key out once;
- a probe on screen is made ready and answered inside its window, after the
  operator's own latencies.

Its looks follow the operator's glance steps and its clicks land its reaction
steps later. On an app whose runner is driven by a `ManualClock` (tests, the
in-process bots), the bot moves the clock to each of those steps, so the live
trial receives its commands at the same steps as `Simulation.apply` does in
process, and both paths give the same requests and decisions for the same seed
and pace (tests/platform/test_synthetic_bot.py). Against a real server the bot
waits for the trial's clock instead, and its commands land when they arrive.
"""

from __future__ import annotations

import heapq
import json
import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from hcss.experiments.synthetic_trials import glance_steps, reaction_steps
from hcss.platform.live.idempotency import KEY_HEADER
from hcss.simulation import Display
from hcss.simulation.synthetic import ObservationClick, SyntheticOperator

#: Answers that mean "not now" (the server holds the command back, or a proxy lost its answer).
PASSING = frozenset({502, 503, 504})
RETRY_FIRST_S = 0.5
RETRY_LIMIT_S = 60.0
PROBE_CHECK_S = 2.0  # how often, in trial seconds, the operator notices a probe on screen


class Client(Protocol):
    """What the bot needs of an HTTP client: Flask's test client or `HttpTransport`."""

    def get(self, url: str, **kwargs: Any) -> Any: ...

    def post(self, url: str, **kwargs: Any) -> Any: ...


@dataclass
class BotLog:
    """Every command the bot sent, its answer, and the frames it looked at."""

    requests: list[dict[str, Any]] = field(default_factory=list)
    observations: list[dict[str, Any]] = field(default_factory=list)
    probes: list[dict[str, Any]] = field(default_factory=list)
    keys: list[str] = field(default_factory=list)
    retries: int = 0
    looks: int = 0


class SyntheticBot:
    """One synthetic participant supervising one live trial through its page's API."""

    def __init__(
        self,
        client: Client,
        api: str,
        csrf: str,
        operator: SyntheticOperator,
        *,
        dt_s: float = 1.0,
        duration_s: float,
        move_clock: Callable[[float], None] | None = None,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.client = client
        self.api = api
        self.headers = {"X-CSRFToken": csrf}
        self.operator = operator
        self.dt = dt_s
        self.duration_s = duration_s
        self.move_clock = move_clock
        self.sleep = sleep
        self.after = ""
        self.log = BotLog()
        self._probe_done: set[int] = set()

    # ---- the page's protocol ------------------------------------------------------
    def frame(self) -> dict[str, Any]:
        """One frame of the event stream, opened after the last message id seen."""
        url = self.api + "/stream" + (f"?after={self.after}" if self.after else "")
        response = self.client.get(url, buffered=False)
        try:
            if response.status_code != 200:
                raise RuntimeError(f"the stream answered {response.status_code}")
            return self._first_frame(response)
        finally:
            response.close()

    def _first_frame(self, response: Any) -> dict[str, Any]:
        event: dict[str, str] = {}
        pending = ""
        for chunk in response.response:
            pending += chunk.decode() if isinstance(chunk, bytes) else chunk
            while "\n\n" in pending:
                block, pending = pending.split("\n\n", 1)
                for line in block.splitlines():
                    name, _, value = line.partition(": ")
                    event[name] = value
                if "data" in event:
                    if event.get("id"):
                        self.after = event["id"]
                    return dict(json.loads(event["data"]))
                event = {}
        raise RuntimeError("the stream closed before a frame")

    def send(self, path: str, body: dict[str, Any]) -> dict[str, Any]:
        """POST a command with a fresh Idempotency-Key; the same key again on 502/503/504."""
        key = secrets.token_hex(16)
        self.log.keys.append(key)
        headers = self.headers | {KEY_HEADER: key}
        waited, attempt = 0.0, 0
        while True:
            response = self.client.post(self.api + path, json=body, headers=headers)
            if response.status_code not in PASSING:
                answer = response.get_json(silent=True) or {}
                if response.status_code >= 400 and response.status_code != 409:
                    raise RuntimeError(f"{path} answered {response.status_code}: {answer}")
                return dict(answer)
            wait = min(RETRY_FIRST_S * 2**attempt, _retry_after(response))
            if waited + wait > RETRY_LIMIT_S:
                raise RuntimeError(f"{path} was held back for over {RETRY_LIMIT_S:g} s")
            self.log.retries += 1
            self.sleep(wait)
            waited, attempt = waited + wait, attempt + 1

    # ---- supervising -------------------------------------------------------------
    def supervise(self) -> BotLog:
        """Look, click and answer probes until the trial's time limit."""
        react = reaction_steps(self.operator.traits, self.dt)
        last = int(round(self.duration_s / self.dt))
        queue: list[tuple[int, int, str, Any]] = []
        order = 0

        def push(step: int, kind: str, payload: Any = None) -> None:
            nonlocal order
            heapq.heappush(queue, (step, order, kind, payload))
            order += 1

        for step in glance_steps(self.operator, self.dt, self.duration_s):
            push(step, "look")
        check = max(1, round(PROBE_CHECK_S / self.dt))
        for step in range(check, last, check):
            push(step, "probe")
        while queue:
            step, _, kind, payload = heapq.heappop(queue)
            if step >= last:
                break
            frame = self._at(step)
            if frame["trial"]["status"] == "ended":
                break
            if kind == "look":
                self.log.looks += 1
                glance = self.operator.look(Display.from_json(frame["view"]))
                for command in glance.commands:
                    push(step + react, "command", command)
                for click in glance.observations:
                    push(step + react, "observe", click)
            elif kind == "command":
                answer = self.send("/requests", payload.to_json())
                self.log.requests.append({"step": step, **payload.to_json(), "answer": answer})
            elif kind == "observe":
                self._observe(step, frame, payload)
            elif kind == "probe":
                self._probe(step, frame, push)
            elif kind == "ready":
                self.send(f"/probes/{payload}/ready", {})
            elif kind == "answer":
                self._answer(step, frame, payload)
        return self.log

    def _at(self, step: int) -> dict[str, Any]:
        """The frame at this step: the clock moved there (manual clock), or waited for."""
        if self.move_clock is not None:
            self.move_clock(step * self.dt)
            return self.frame()
        while True:
            frame = self.frame()
            if frame["trial"]["status"] == "ended" or frame["view"]["step"] >= step:
                return frame
            self.sleep(0.05)

    def _observe(self, step: int, frame: dict[str, Any], click: ObservationClick) -> None:
        """Click, unless the clicked target has left the map since the look: the page draws
        only the targets it shows, so a person's click there lands on nothing."""
        shown = {t["id"] for t in frame["view"]["targets"]}
        if click.kind == "target" and click.target not in shown:
            return
        self.send("/observations", click.to_json())
        self.log.observations.append({"step": step, **click.to_json()})

    def _probe(self, step: int, frame: dict[str, Any], push: Callable[..., None]) -> None:
        probe = frame.get("probe")
        if not probe or probe["id"] in self._probe_done:
            return
        self._probe_done.add(probe["id"])
        t = self.operator.traits
        ready = step + max(1, round(t.probe_ready_s / self.dt))
        push(ready, "ready", probe["id"])
        push(ready + max(1, round(t.probe_answer_s / self.dt)), "answer", probe["id"])

    def _answer(self, step: int, frame: dict[str, Any], probe_id: int) -> None:
        probe = frame.get("probe")
        if not probe or probe["id"] != probe_id or probe["phase"] != "question":
            return  # timed out, or not yet shown as a question: nothing to answer
        answer = self.operator.answer(probe["level"], probe["question"], probe["choices"])
        self.send(f"/probes/{probe_id}/answer", {"answer": answer})
        self.log.probes.append({"step": step, "id": probe_id, "answer": answer})


def _retry_after(response: Any) -> float:
    try:
        seconds = float(response.headers.get("Retry-After", ""))
    except ValueError:
        return 5.0
    return min(seconds, RETRY_LIMIT_S) if seconds > 0 else 5.0
