"""Operator requests (spec §8): investigate, abandon, cancel and decide.

One value crosses the API each way: an `OperatorCommand` in (the platform
builds it once from the participant's JSON, stores its fields and builds it
again from the stored row for a replay; the scripted operators build it from
what they see), a `RequestOutcome` out. Validation happens before anything
changes, so a refusal leaves the simulation exactly as it was. Accepted
requests act only on agents in the collective's hub area; those that need
several agents (investigate, decide) stay in progress and pick agents up as
they arrive in the hub. Each status a request passes through (in progress,
completed, removed) is queued as a `StatusChange` for the platform to drain,
as it drains events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.ids import target_id
from hcss.simulation.messages import collective_name
from hcss.simulation.params import Params

if TYPE_CHECKING:
    from hcss.simulation.world import World

KINDS = ("investigate", "abandon", "decide", "cancel")
IN_PROGRESS, COMPLETED, REMOVED = "in_progress", "completed", "removed"


@dataclass(frozen=True)
class OperatorCommand:
    """One operator command, as `Simulation.apply` takes it.

    `collective` is 0-based, `target` the public (1-based) id, `request_id`
    the assignment a cancel lifts. The fields are not checked here: the
    simulation refuses what does not fit the trial, with a reason.
    """

    kind: str
    collective: int | None = None
    target: int | None = None
    request_id: int | None = None

    @classmethod
    def cancel(cls, request_id: int) -> OperatorCommand:
        return cls("cancel", request_id=request_id)

    def to_json(self) -> dict[str, Any]:
        """The command as the platform's request endpoint takes it (a bot's POST body)."""
        if self.kind == "cancel":
            return {"kind": "cancel", "request_id": self.request_id}
        return {"kind": self.kind, "collective": self.collective, "target": self.target}

    def key(self) -> tuple[str, int | None, int | None, int | None]:
        """What makes two commands the same click (the request id only for a cancel)."""
        return (self.kind, self.collective, self.target, self.request_id)


@dataclass(frozen=True)
class RequestOutcome:
    """What the simulation answers to a command, and the context it was applied in.

    - `request_id`: the new request's id; for a cancel, the lifted one's.
    - `collective`, `target` (public id): what the command was about; for a
      cancel, the lifted abandon's. None when the command names none.
    - `support`: the fraction of the collective favouring the target just
      before the command, for a target the operator can see; else None.
    - `decision_index`: the collective's decision under way (1-based), None
      when it has none (the trial is over) or the collective does not exist.
    - `intervention`: an accepted abandon of a target at or above
      `Params.intervention_support`.
    """

    accepted: bool
    request_id: int | None = None
    reason: str = ""
    collective: int | None = None
    target: int | None = None
    support: float | None = None
    decision_index: int | None = None
    intervention: bool = False


@dataclass(frozen=True)
class RequestState:
    """A request as the Collective Assignments list shows it."""

    id: int
    kind: str
    collective: int
    target: int  # public id
    status: str  # IN_PROGRESS or COMPLETED
    acknowledged: int


@dataclass(frozen=True)
class StatusChange:
    """A request entered `status` (IN_PROGRESS, COMPLETED or REMOVED) at this step and time."""

    request_id: int
    status: str
    step: int
    time: float


@dataclass
class Request:
    """An accepted request and its progress."""

    id: int
    kind: str
    collective: int
    target: int  # array index; public outputs use ids.target_id(target)
    needed: int  # agents still to acknowledge; 0 for a standing abandon
    acknowledged: int = 0
    active: bool = True  # False once cancelled or when the collective's decision ends
    support: float = 0.0  # fraction favouring the target when requested

    noted: str = ""  # the newest status queued as a StatusChange

    @property
    def status(self) -> str:
        if self.kind == "abandon":
            return IN_PROGRESS if self.active else COMPLETED
        return COMPLETED if self.needed == 0 else IN_PROGRESS

    def state(self) -> RequestState:
        return RequestState(
            self.id,
            self.kind,
            self.collective,
            target_id(self.target),
            self.status,
            self.acknowledged,
        )


def executing(world: World, collective: int) -> bool:
    """A collective is executing a move while any of its agents initiate or fly to the site."""
    mine = world.collective == collective
    return bool(np.any(mine & ((world.state == S.I) | (world.state == S.X))))


def refusal(world: World, params: Params, kind: str, collective: int, target: int) -> str:
    """Why a request for (collective, target index) is invalid, or "" if it is valid."""
    if world.finished:
        return "The trial is over."
    if not 0 <= collective < world.n_collectives:
        return f"There is no collective {collective + 1}."
    name = collective_name(collective)
    if not 0 <= target < world.active.size or not world.active[target]:
        return f"There is no target {target_id(target)}."
    if world.report_count[target] < params.visible_reports:
        return f"Target {target_id(target)} has not been discovered yet."
    owner = int(world.reserved_by[target])
    if owner >= 0 and owner != collective:
        return f"Target {target_id(target)} is taken by collective {collective_name(owner)}."
    if executing(world, collective):
        return f"Collective {name} is executing a move and cannot take requests."
    support_count = int(
        np.sum((world.collective == collective) & world.favouring() & (world.target == target))
    )
    if kind == "investigate":
        if world.hub_distance[collective, target] > params.exploration_range_m:
            return f"Target {target_id(target)} is out of range of collective {name}."
        if world.abandon_order[collective, target]:
            return f"Collective {name} has an abandon order for target {target_id(target)}; cancel it first."
    elif kind == "abandon":
        if world.abandon_order[collective, target]:
            return f"Collective {name} is already abandoning target {target_id(target)}."
        if support_count < params.abandon_min_supporters:
            robots = "robot" if support_count == 1 else "robots"
            favour = "favours" if support_count == 1 else "favour"
            return (
                f"Only {support_count} {robots} of collective {name} {favour} target "
                f"{target_id(target)}; abandon needs at least {params.abandon_min_supporters}."
            )
    elif kind == "decide":
        share = support_count / params.n_agents
        if share < params.decide_min_support:
            # rounded down to a tenth of a point: 59 of 200 is "29.5%", never "30%" below 30%
            shown = math.floor(share * 1000) / 10
            robots = "robot" if support_count == 1 else "robots"
            favour = "favours" if support_count == 1 else "favour"
            return (
                f"Only {support_count} {robots} ({shown:g}%) of collective {name} {favour} "
                f"target {target_id(target)}; decide needs at least "
                f"{params.decide_min_support:.0%}."
            )
    else:
        return f"Unknown request type {kind!r}."
    return ""


def recruit_for(world: World, request: Request, rng: np.random.Generator) -> None:
    """Hand an in-progress investigate or decide request the agents it still needs."""
    if request.needed == 0 or not request.active:
        return
    mine_in_hub = (world.collective == request.collective) & (world.leg == S.AT_HUB)
    if request.kind == "investigate":
        pool = np.flatnonzero(mine_in_hub & (world.state == S.U_I))
        chosen = _take(pool, request.needed, rng)
        world.set_state(chosen, S.F_L, request.target)
        world.leg[chosen] = S.TO_TARGET
    else:  # decide: supporters of the target first, else uncommitted agents
        supporters = np.flatnonzero(
            mine_in_hub & S.FAVOURING_IN_HUB[world.state] & (world.target == request.target)
        )
        chosen = _take(supporters, request.needed, rng)
        if chosen.size < request.needed:
            uncommitted = np.flatnonzero(mine_in_hub & (world.state == S.U_I))
            chosen = np.r_[chosen, _take(uncommitted, request.needed - chosen.size, rng)].astype(
                np.int64
            )
        world.set_state(chosen, S.C, request.target)
    request.acknowledged += int(chosen.size)
    request.needed -= int(chosen.size)


def _take(pool: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    if pool.size <= n:
        return pool
    return rng.choice(pool, size=n, replace=False)
