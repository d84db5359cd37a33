"""A participant's trial runs the batch experiment's model: its preset's params but the time-out."""

from __future__ import annotations

import tomllib
from dataclasses import fields

import pytest

from hcss.platform.models import Trial
from hcss.platform.study.files import study_text
from hcss.platform.study.studyfile import StudyFileError, load_study, parse_study
from hcss.simulation import Params
from hcss.simulation.presets import DEFAULT_PRESET, preset_params


def _differing(a: Params, b: Params) -> list[str]:
    return [f.name for f in fields(Params) if getattr(a, f.name) != getattr(b, f.name)]


def test_a_live_m2_trial_is_the_batch_experiments_m2_apart_from_the_decision_timeout(
    make_trial,
) -> None:
    handle = make_trial(model="M2", preset=None)  # a trial whose study names no preset
    live = handle.live()
    batch = preset_params(DEFAULT_PRESET)  # what `hcss simulate experiment` runs by default
    assert _differing(live.sim.params, batch) == ["decision_timeout_s"]
    assert live.sim.params.decision_timeout_s is None
    assert live.sim.params.preset == DEFAULT_PRESET
    # The trial row stores them, preset named, and a rebuild reads the same model back.
    database = handle.app.extensions["hcss_db"]
    with database.session_scope() as session:
        stored = Params.from_dict(session.get(Trial, handle.trial_id).params)
    assert stored == live.sim.params


def test_the_bundled_studies_keep_the_preset_they_name_and_their_trials_use_it(
    make_trial,
) -> None:
    """The default moved to study-units; a study file that names a preset keeps it, so the
    bundled studies' live trials (and their decisions' label) did not change with it."""
    for name in ("original", "demo"):
        assert "[simulation]" in study_text(name)[1].decode()
        assert load_study(name).simulation.preset == "study-calibrated" != DEFAULT_PRESET
    handle = make_trial(model="M1", preset=load_study("original").simulation.preset)
    expected = preset_params("study-calibrated").with_changes(decision_timeout_s=None)
    assert handle.live().sim.params == expected
    handle = make_trial(model="M1", preset="literal")
    assert handle.live().sim.params == Params().with_changes(decision_timeout_s=None)


def test_a_study_file_names_a_preset_or_is_refused_naming_the_presets() -> None:
    doc = tomllib.loads(study_text("original")[1].decode())
    doc["simulation"] = {"preset": "literal"}
    assert parse_study(doc, source="t").simulation.preset == "literal"
    del doc["simulation"]
    assert parse_study(doc, source="t").simulation.preset == DEFAULT_PRESET
    for bad in ({"preset": "bogus"}, {"preset": 3}, {"preset": "literal", "r_msg": 2}):
        doc["simulation"] = bad
        with pytest.raises(StudyFileError, match=r"simulation"):
            parse_study(doc, source="t")


def test_a_live_trials_scenario_is_drawn_under_its_presets_layout_reading(
    make_trial,
) -> None:
    from hcss.simulation import Scenario

    handle = make_trial(model="M1", preset="study-units", seed=11)
    params = preset_params("study-units")
    assert params.easy_layout_others == "strictly_farther"
    database = handle.app.extensions["hcss_db"]
    with database.session_scope() as session:
        stored = session.get(Trial, handle.trial_id).scenario
    assert stored == Scenario.generate(11, first_section="easy", params=params).to_dict()
    assert stored != Scenario.generate(11, first_section="easy").to_dict()
