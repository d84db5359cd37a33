"""Every table of the platform; importing this package registers them all on `Base`."""

from hcss.platform.models.append_only import APPEND_ONLY_TABLES, DeletionPermit
from hcss.platform.models.base import Base, CreatedAt, UTCDateTime
from hcss.platform.models.console import (
    AuditRecord,
    ConsoleAction,
    ConsoleForm,
    Experimenter,
    LoginFailure,
)
from hcss.platform.models.group import GroupStudy
from hcss.platform.models.idempotency import CommandKey
from hcss.platform.models.join_start import JoinStart
from hcss.platform.models.lease import GroupMember, TrialLease
from hcss.platform.models.observation import Observation
from hcss.platform.models.order import TrialOrder
from hcss.platform.models.outcome import DecisionRow, SimEvent
from hcss.platform.models.participant import Participant, new_code, new_token
from hcss.platform.models.presence import ParticipantPresence
from hcss.platform.models.probe import Probe, ProbeEvent
from hcss.platform.models.recruitment import Recruitment, ReturnVisit, ScreenOut, TurnedAway
from hcss.platform.models.requests import (
    COMMAND_KINDS,
    Command,
    CommandOutcome,
    RequestStatusChange,
)
from hcss.platform.models.study import (
    ConsentRecord,
    QuestionnaireItem,
    Score,
    StageEvent,
    StudyEnrolment,
)
from hcss.platform.models.trial import (
    Interruption,
    Snapshot,
    Trial,
    TrialProblem,
    TrialStatusChange,
)

__all__ = [
    "APPEND_ONLY_TABLES",
    "DeletionPermit",
    "COMMAND_KINDS",
    "AuditRecord",
    "ConsoleAction",
    "ConsoleForm",
    "Experimenter",
    "Base",
    "Command",
    "ConsentRecord",
    "CommandOutcome",
    "CommandKey",
    "CreatedAt",
    "DecisionRow",
    "GroupStudy",
    "Interruption",
    "JoinStart",
    "LoginFailure",
    "Observation",
    "Participant",
    "ParticipantPresence",
    "Probe",
    "ProbeEvent",
    "QuestionnaireItem",
    "Recruitment",
    "RequestStatusChange",
    "ReturnVisit",
    "TurnedAway",
    "Score",
    "ScreenOut",
    "SimEvent",
    "Snapshot",
    "StageEvent",
    "StudyEnrolment",
    "Trial",
    "TrialLease",
    "GroupMember",
    "TrialOrder",
    "TrialProblem",
    "TrialStatusChange",
    "UTCDateTime",
    "new_code",
    "new_token",
]
