"""The export's tables and their column types, as docs/data-dictionary.md lists them.

The column lists are the contract with `hcss.analysis`; a test reads the
data dictionary and checks them against it, so neither can drift alone. The
types choose the Parquet schema; CSV writes every type as text.
"""

from __future__ import annotations

from hcss.simulation import DECISION_COLUMNS, MODELS

#: Column types of the decisions table; the columns themselves are DECISION_COLUMNS.
_DECISION_TYPES = {
    "run": "int",
    "seed": "int",
    "section": "int",
    "decision_index": "int",
    "start_s": "float",
    "end_s": "float",
    "decision_time_s": "float",
    "timed_out": "bool",
    "chosen_target": "int",
    "chosen_value": "float",
    "chosen_distance_m": "float",
    "best_target": "int",
    "best_value": "float",
    "correct": "bool",
    "n_requests": "int",
    "n_investigate": "int",
    "n_abandon": "int",
    "n_decide": "int",
    "n_interventions": "int",
}

_TRIAL_KEYS = (
    ("participant", "str"),
    ("trial_id", "str"),
    ("model", "str"),
    ("sim_time_s", "float"),
    ("wall_time", "str"),
)

DEMOGRAPHICS = ("age_band", "gender", "education", "colour_vision", "video_games", "robots")

TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "decisions": tuple((name, _DECISION_TYPES.get(name, "str")) for name in DECISION_COLUMNS),
    "participants": (
        ("participant", "str"),
        ("study", "str"),
        ("study_digest", "str"),
        ("cell", "int"),
        ("model_order", "str"),
        ("is_pilot", "bool"),
        ("is_bot", "bool"),
        ("is_demo", "bool"),
        ("status", "str"),
        *((name, "str") for name in DEMOGRAPHICS),
        ("mrt_score", "int"),
        *((f"tlx_overall_{model}", "float") for model in MODELS),
        *((f"sart_{model}", "float") for model in MODELS),
    ),
    "recruitment": (
        ("participant", "str"),
        ("study", "str"),
        ("source", "str"),
        ("recruitment_id", "str"),
        ("recruiter_study_id", "str"),
        ("recruiter_session_id", "str"),
        ("enrolled_at", "str"),
    ),
    "return_visits": (
        ("participant", "str"),
        ("study", "str"),
        ("source", "str"),
        ("recruitment_id", "str"),
        ("recruiter_study_id", "str"),
        ("recruiter_session_id", "str"),
        ("visited_at", "str"),
    ),
    "screen_outs": (
        ("study", "str"),
        ("source", "str"),
        ("recruitment_id", "str"),
        ("width", "int"),
        ("height", "int"),
        ("mobile", "bool"),
        ("missing", "str"),
        ("reasons", "str"),
        ("screened_out_at", "str"),
    ),
    "requests": (
        *_TRIAL_KEYS,
        ("request_id", "int"),
        ("kind", "str"),
        ("collective", "str"),
        ("target", "int"),
        ("accepted", "bool"),
        ("reason", "str"),
        ("support", "float"),
        ("intervention", "bool"),
        ("decision_index", "int"),
    ),
    "observations": (
        *_TRIAL_KEYS,
        ("kind", "str"),
        ("collective", "str"),
        ("target", "int"),
        ("button", "str"),
    ),
    "probes": (
        *_TRIAL_KEYS,
        ("probe_index", "int"),
        ("level", "int"),
        ("question", "str"),
        ("ready_latency_ms", "float"),
        ("answer_latency_ms", "float"),
        ("answer", "str"),
        ("truth", "str"),
        ("correct", "bool"),
        ("timed_out", "bool"),
        ("fast_answer", "bool"),
    ),
    "questionnaire_items": (
        ("participant", "str"),
        ("wall_time", "str"),
        ("instrument", "str"),
        ("model", "str"),
        ("item", "str"),
        ("value", "str"),
    ),
    "scores": (
        ("participant", "str"),
        ("instrument", "str"),
        ("model", "str"),
        ("scale", "str"),
        ("score", "float"),
    ),
    "stage_timings": (
        ("participant", "str"),
        ("stage_index", "int"),
        ("stage", "str"),
        ("model", "str"),
        ("entered_at", "str"),
        ("submitted_at", "str"),
        ("timed_out", "bool"),
        ("skipped", "bool"),
    ),
    "interruptions": (
        ("participant", "str"),
        ("trial_id", "str"),
        ("trial_kind", "str"),
        ("model", "str"),
        ("last_seen_at", "str"),
        ("resumed_at", "str"),
        ("outage_s", "float"),
        ("resumed_step", "int"),
        ("resumed_sim_time_s", "float"),
        ("replayed_commands", "int"),
    ),
    "export_problems": (
        ("participant", "str"),
        ("trial_id", "str"),
        ("table", "str"),
        ("record", "str"),
        ("problem", "str"),
    ),
}

#: Records the export could not read; see hcss.platform.export.problems.
PROBLEMS_TABLE = "export_problems"

#: Tables of what happens inside a trial; training trials get their own copies.
TRIAL_TABLES = ("decisions", "requests", "observations", "probes")


def columns(table: str) -> tuple[str, ...]:
    return tuple(name for name, _ in TABLES[table])
