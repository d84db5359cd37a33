"""The study export's tables beside decisions (`hcss export OUTDIR`), in the dictionary's order."""

from __future__ import annotations

from hcss.tablespec.decisions import DECISIONS
from hcss.tablespec.spec import Column, TableSpec

#: The models of the original design, as the participants table's per-model columns name them.
MODELS = ("M1", "M2", "M3")
DEMOGRAPHICS = ("age_band", "gender", "education", "colour_vision", "video_games", "robots")


def _trial_keys(when: str) -> tuple[Column, ...]:
    """The keys every row of a trial table starts with; `when` says which moment the times are."""
    return (
        Column("participant", "str", "participant code", nullable=False, required=True),
        Column("trial_id", "str", "the trial", nullable=False, required=True),
        Column("model", "str", "the trial's model", nullable=False, required=True),
        Column("sim_time_s", "float", f"simulation time (seconds from the trial's start) {when}"),
        Column("wall_time", "str", f"ISO 8601 UTC {when}"),
    )


PARTICIPANTS = TableSpec(
    name="participants",
    title="participants (wide: one row per participant)",
    description="",
    columns=(
        Column("participant", "str", "participant code", nullable=False, required=True),
        Column(
            "study",
            "str",
            "study file name, e.g. `original`: of the newest enrolment, else the study chosen "
            "when the participant was created",
        ),
        Column(
            "study_digest",
            "str",
            "sha256 of the study file the participant started with; empty before they opened "
            "their link",
        ),
        Column("cell", "int", "counterbalancing cell (1–8 in the original design)"),
        Column("model_order", "str", "models in the order met, e.g. `M2,M1,M3`"),
        Column("is_pilot", "bool", "pilot participant", required=True),
        Column("is_bot", "bool", "participant bot", required=True),
        Column("is_demo", "bool", "demo participant (`hcss demo-trial`)", required=True),
        Column(
            "status",
            "str",
            "`not_started` (the link was never opened: no study file was run, `study_digest` "
            "and `cell` are empty; the analysis sets these rows aside), `in_progress`, "
            "`completed`, `declined`, `aborted`, `timed_out` (the study file's `[timeouts]`). "
            "A participant outside the study flow (`hcss demo-trial`) is `in_progress` while a "
            "trial runs, `completed` after",
        ),
        *(Column(name, "str", "demographics answers") for name in DEMOGRAPHICS),
        Column(
            "mrt_score",
            "int",
            "Mental Rotations Test score: items right over the study's timed parts (0–24 in "
            "the original's two parts of 12)",
        ),
        Column(
            "mrt_part_items",
            "str",
            "the study file's items per timed MRT part, comma-separated (`12,12` in the "
            "original, `4` in the demo): `mrt_score` runs from 0 to their sum",
        ),
        *(
            Column(f"tlx_overall_{model}", "float", f"weighted NASA-TLX of {model}")
            for model in MODELS
        ),
        *(Column(f"sart_{model}", "float", f"3-D SART score of {model}") for model in MODELS),
    ),
)

RECRUITMENT = TableSpec(
    name="recruitment",
    title="recruitment",
    description="""
One row per participant who came through a study link (`/join/<study>`).
These ids link a participant code to an account on the recruitment site:
use them to approve and pay, and leave this file out of shared data.
An id that a spreadsheet would run as a formula (starting with `=`, `+`,
`-`, `@`, a tab or a carriage return), that pandas reads as missing (`NaN`,
`null`, `NA`, `None`, ...) or that starts with `'` is written with one
leading `'`: strip it to get the id as the site sent it.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column("study", "str", "study file the link enrolled them in", nullable=False),
        Column(
            "source",
            "str",
            "`prolific`, `sona`, `mturk`, or `link` (no recruitment id given)",
            nullable=False,
        ),
        Column(
            "recruitment_id",
            "str",
            "the site's id of the person: `PROLIFIC_PID`, SONA `id`, MTurk `workerId`",
        ),
        Column("recruiter_study_id", "str", "Prolific `STUDY_ID` or MTurk `hitId`"),
        Column("recruiter_session_id", "str", "Prolific `SESSION_ID` or MTurk `assignmentId`"),
        Column("enrolled_at", "str", "ISO 8601 UTC of the first visit"),
    ),
)

RETURN_VISITS = TableSpec(
    name="return_visits",
    title="return_visits",
    description="""
One row per later visit of an enrolled participant through the study link
(`/join/<study>` with a recruitment id the study has seen), each with the ids
that visit carried: Prolific gives a returning person a new `SESSION_ID`.
`recruitment` keeps the first visit's ids unchanged. Ids are written like
`recruitment`'s; leave this file out of shared data.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column("study", "str", "study file the link enrolled them in", nullable=False),
        Column("source", "str", "`prolific`, `sona`, `mturk`, or `link`", nullable=False),
        Column("recruitment_id", "str", "the site's id of the person (as in `recruitment`)"),
        Column("recruiter_study_id", "str", "this visit's Prolific `STUDY_ID` or MTurk `hitId`"),
        Column(
            "recruiter_session_id",
            "str",
            "this visit's Prolific `SESSION_ID` or MTurk `assignmentId`",
        ),
        Column("visited_at", "str", "ISO 8601 UTC of the visit"),
    ),
)

SCREEN_OUTS = TableSpec(
    name="screen_outs",
    title="screen_outs",
    description="""
One row per visitor the study link's first page turned away before consent,
because their device fell short of the study file's `[requirements]`. No
participant is created for them. Like `recruitment`, it holds the site's ids:
leave it out of shared data.
""".strip(),
    columns=(
        Column("study", "str", "study file of the link", nullable=False),
        Column(
            "source",
            "str",
            "`prolific`, `sona`, `mturk`, or `link` (no recruitment id given)",
            nullable=False,
        ),
        Column(
            "recruitment_id",
            "str",
            "the site's id of the person, when the link gave one (written like `recruitment`'s)",
        ),
        Column(
            "width",
            "int",
            "the browser window's width in CSS pixels, as the first page measured it",
        ),
        Column("height", "int", "the window's height in CSS pixels"),
        Column(
            "mobile",
            "bool",
            "the browser reported a phone or tablet (or a touch-only pointer)",
        ),
        Column(
            "missing",
            "str",
            "browser features the study needs and the browser lacks, comma-separated",
        ),
        Column("reasons", "str", "each shortfall, in the words the visitor was shown"),
        Column("screened_out_at", "str", "ISO 8601 UTC"),
    ),
)

REQUESTS = TableSpec(
    name="requests",
    title="requests",
    description="",
    columns=(
        *_trial_keys("of the request"),
        Column(
            "request_id",
            "int",
            "the simulation's id for an accepted request; empty when refused",
        ),
        Column("kind", "str", "`investigate`, `abandon`, `cancel`, `decide`", required=True),
        Column("collective", "str", "`I`–`IV`"),
        Column("target", "int", "target id"),
        Column("accepted", "bool", "the simulation accepted the request", required=True),
        Column("reason", "str", "refusal reason; empty when accepted"),
        Column(
            "support",
            "float",
            "fraction of the collective favouring the target just before the request (empty "
            "for a target not shown on the map)",
        ),
        Column(
            "intervention",
            "bool",
            "an accepted abandon issued with `support >=` `Params.intervention_support` "
            "(0.10); the simulation's own flag, as counted in `n_interventions`",
            required=True,
        ),
        Column(
            "decision_index",
            "int",
            "the collective's decision under way when the request was made (empty when none "
            "is: the trial is over)",
        ),
    ),
)

OBSERVATIONS = TableSpec(
    name="observations",
    title="observations",
    description="",
    columns=(
        *_trial_keys("of the click"),
        Column("kind", "str", "`collective` or `target`", required=True),
        Column("collective", "str", "clicked collective, if any"),
        Column("target", "int", "clicked target, if any"),
        Column("button", "str", "`left` or `right`"),
    ),
)

PROBES = TableSpec(
    name="probes",
    title="probes",
    description="",
    columns=(
        *_trial_keys("when the probe was shown"),
        Column("probe_index", "int", "1-based within the trial"),
        Column("level", "int", "1 perception, 2 comprehension, 3 projection", required=True),
        Column("question", "str", "the filled-in question"),
        Column(
            "ready_latency_ms",
            "float",
            "wall-clock milliseconds from the server's first delivery of the prompt to the page "
            'until the "ready" press reached the server (an experimenter\'s pause does not '
            "count); empty if never pressed",
        ),
        Column(
            "answer_latency_ms",
            "float",
            "wall-clock milliseconds from the server's first delivery of the question until the "
            "answer reached the server (pauses excluded); empty if unanswered",
        ),
        Column("answer", "str", "the participant's answer; empty if unanswered"),
        Column("truth", "str", "the correct answer from the simulation"),
        Column(
            "correct",
            "bool",
            "empty until scored (level 3 is scored when the next decision happens)",
            required=True,
        ),
        Column("timed_out", "bool", "unanswered after 30 s", required=True),
        Column(
            "fast_answer",
            "bool",
            "answered sooner than the study file's `[probes] fast_answer_ms` (1000 ms by "
            "default) after the question reached the page: likely not read; empty if unanswered",
        ),
    ),
)

QUESTIONNAIRE_ITEMS = TableSpec(
    name="questionnaire_items",
    title="questionnaire_items",
    description="",
    columns=(
        Column("participant", "str", "participant code", nullable=False, required=True),
        Column("wall_time", "str", "ISO 8601 UTC of the answer"),
        Column(
            "instrument",
            "str",
            "`demographics`, `mrt`, `instruction_check`, `post_trial`, `nasa_tlx`, `sart`, "
            "`ranking`",
            required=True,
        ),
        Column(
            "model",
            "str",
            "the model the answer is about; empty for per-participant instruments",
            required=True,
        ),
        Column(
            "item",
            "str",
            "item key, e.g. `mental_demand`, `pair_03`, `mrt_07`; an instruction check's answers "
            "are `<question key>_try_<n>`, one per question and try (the study file's "
            "`[instruction_check]` names the questions and their answers)",
            required=True,
        ),
        Column("value", "str", "the raw answer", required=True),
    ),
)

SCORES = TableSpec(
    name="scores",
    title="scores",
    description="",
    columns=(
        Column("participant", "str", "participant code", nullable=False, required=True),
        Column(
            "instrument",
            "str",
            "`mrt`, `instruction_check`, `nasa_tlx`, `sart`, `post_trial`, `ranking`",
            required=True,
        ),
        Column("model", "str", "empty for per-participant instruments", required=True),
        Column(
            "scale",
            "str",
            "e.g. `overall`, `raw_tlx`, `mental_demand_weighted`, `SU`, `effectiveness`, "
            "`responsiveness`; the instruction check's `passed` (1: a try answered every "
            "question rightly, 0: the last try did not) and `tries` (how many were used)",
            required=True,
        ),
        Column("score", "float", "the instrument's score on that scale", required=True),
    ),
)

STAGE_TIMINGS = TableSpec(
    name="stage_timings",
    title="stage_timings",
    description="",
    columns=(
        Column("participant", "str", "participant code", nullable=False, required=True),
        Column("stage_index", "int", "position in the study's stage list"),
        Column("stage", "str", "stage name, e.g. `consent`, `trial`", required=True),
        Column("model", "str", "for per-model stages"),
        Column("entered_at", "str", "ISO 8601 UTC", required=True),
        Column("submitted_at", "str", "ISO 8601 UTC", required=True),
        Column("timed_out", "bool", "the stage's deadline passed before submission"),
        Column(
            "skipped",
            "bool",
            "the experimenter moved the participant past a step of this stage (console "
            '"Skip stage", audited); `submitted_at` is then when',
        ),
    ),
)

LATE_ANSWERS = TableSpec(
    name="late_answers",
    title="late_answers",
    description="""
Answers sent from a page after the experimenter had skipped its step (console "Skip
stage"): the participant's page was still open and its Continue arrived late. The
participant is told they were kept; they are kept here, apart, never as the step's
answers (`questionnaire_items` holds only answers given while a step was open). One row
per value sent (a field sent twice gives two rows); the first late submit of a step is
kept, at most 200 fields of 200 characters.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column("stage_index", "int", "position in the study's stage list", nullable=False),
        Column("stage", "str", "stage name, e.g. `demographics`", nullable=False),
        Column("step", "str", "the skipped step, e.g. `form`, `part_1`", nullable=False),
        Column("model", "str", "for per-model stages"),
        Column("answered_at", "str", "ISO 8601 UTC: when the late answer arrived"),
        Column("item", "str", "the form field, e.g. `age_band`", nullable=False),
        Column("value", "str", "the value sent"),
    ),
)

INTERRUPTIONS = TableSpec(
    name="interruptions",
    title="interruptions",
    description="""
One row per server restart that found a trial live (training and main trials
alike). While the server is down the trial clock stands still, as in an
experimenter's pause: the trial resumes at the step the server had reached
and its deadline moves on by `outage_s`. Up to one snapshot interval (5 s) of
steps the dead server had computed but not yet written are computed again.
An analyst can leave out, or adjust for, trials with long outages.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column("trial_id", "str", "the trial", nullable=False),
        Column("trial_kind", "str", "`training` or `trial`"),
        Column("model", "str", "the trial's model"),
        Column(
            "last_seen_at",
            "str",
            "ISO 8601 UTC: the newest record the server wrote before it stopped",
        ),
        Column("resumed_at", "str", "ISO 8601 UTC: when the restarted server rebuilt the trial"),
        Column("outage_s", "float", "wall seconds the trial clock stood still for the outage"),
        Column("resumed_step", "int", "the simulation step the trial resumed at"),
        Column(
            "resumed_sim_time_s",
            "float",
            "that step as trial time (seconds from the trial's start)",
        ),
        Column("replayed_commands", "int", "commands replayed from the log to rebuild the state"),
    ),
)

EXPORT_PROBLEMS = TableSpec(
    name="export_problems",
    title="export_problems",
    description="""
Records the export could not read (for example a request naming a collective
the trial does not have, or a value of the wrong type). Each was skipped and
is listed here; every other row was exported. Empty in a healthy export.
""".strip(),
    columns=(
        Column("participant", "str", "participant code, when known"),
        Column("trial_id", "str", "the trial the record belongs to, when it belongs to one"),
        Column(
            "table",
            "str",
            "the table the record would have gone to, e.g. `requests`",
            nullable=False,
        ),
        Column(
            "record",
            "str",
            "which stored record, e.g. `command 17`, `trial 4`, `row 3`",
            nullable=False,
        ),
        Column("problem", "str", "why it could not be read", nullable=False),
    ),
)

#: Every table of an export, decisions first, in the dictionary's order.
EXPORT_TABLES: dict[str, TableSpec] = {
    spec.name: spec
    for spec in (
        DECISIONS,
        PARTICIPANTS,
        RECRUITMENT,
        RETURN_VISITS,
        SCREEN_OUTS,
        REQUESTS,
        OBSERVATIONS,
        PROBES,
        QUESTIONNAIRE_ITEMS,
        SCORES,
        STAGE_TIMINGS,
        LATE_ANSWERS,
        INTERRUPTIONS,
        EXPORT_PROBLEMS,
    )
}
