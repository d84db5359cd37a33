"""The participant's study flow: stages in the style of oTree's page sequence.

A study file (`<name>.toml`: `files` finds it, `studyfile` reads it into `settings.Study`,
the one typed model the platform runs) lists the stages; the stage classes (`stages`,
`mrt_stage`, `trial_stage`) declare their forms, templates, time limits and hooks, each
hook given one `stage_protocol.StageContext`; `flow.Flow` answers "which stage now?" from the
participant's append-only stage events; `enrolment.assign_cell` does the
counterbalancing; `views` serves `/p/<token>`.
"""

from hcss.platform.study.enrolment import assign_cell
from hcss.platform.study.flow import Position, current_position, participant_status
from hcss.platform.study.studyfile import Study, StudyFileError, load_study

__all__ = [
    "Position",
    "Study",
    "StudyFileError",
    "assign_cell",
    "current_position",
    "load_study",
    "participant_status",
]
