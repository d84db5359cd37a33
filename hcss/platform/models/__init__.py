"""Every table of the platform; importing this package registers them all on `Base`."""

from hcss.platform.models.base import Base, CreatedAt, UTCDateTime, utcnow
from hcss.platform.models.observation import Observation
from hcss.platform.models.outcome import DecisionRow, SimEvent
from hcss.platform.models.participant import Participant, new_code, new_token
from hcss.platform.models.probe import Probe, ProbeEvent
from hcss.platform.models.requests import (
    COMMAND_KINDS,
    Command,
    CommandOutcome,
    RequestStatusChange,
)
from hcss.platform.models.trial import Interruption, Snapshot, Trial, TrialStatusChange

__all__ = [
    "COMMAND_KINDS",
    "Base",
    "Command",
    "CommandOutcome",
    "CreatedAt",
    "DecisionRow",
    "Interruption",
    "Observation",
    "Participant",
    "Probe",
    "ProbeEvent",
    "RequestStatusChange",
    "SimEvent",
    "Snapshot",
    "Trial",
    "TrialStatusChange",
    "UTCDateTime",
    "new_code",
    "new_token",
    "utcnow",
]
