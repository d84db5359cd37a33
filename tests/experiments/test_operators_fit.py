"""`hcss simulate calibrate --to study-teams`: a small search, its files, its resume."""

from __future__ import annotations

import json

import pytest

from hcss.experiments import operators_fit as of


def test_a_small_calibration_writes_its_fit_and_report_and_resumes_only_the_same_search(
    tmp_path,
) -> None:
    out = tmp_path / "operators"
    small = {"participants": 2, "validation_participants": 2, "selection_participants": 2}
    settings = of.Settings(budget=2, **small)
    first = of.calibrate(out, settings, workers=1)
    assert first.trials == 2
    fitted = json.loads((out / "population.json").read_text(encoding="utf-8"))
    assert fitted["trial"] == first.chosen.trial and first.fit == first.chosen.population
    assert set(fitted["median"]) == set(of.Traits().to_dict())
    assert fitted["preset"] == of.default_params().preset
    report = (out / "report.md").read_text(encoding="utf-8")
    assert all(f"Held-out block {block}" in report for block in of.VALIDATION_BLOCKS)
    # beside each block's cells met, what a perfect population of its size would meet
    assert f"would meet {of.teams.ceiling(2)[0]:.1f} cells" in report
    # and with decisions clustered by person as the block's own are
    block = first.validations[0]
    assert block.effects and all(v >= 0 for v in block.effects.values())
    assert f"are (design effects {min(block.effects.values()):.2f}" in report.replace("\n", " ")
    assert f"{of.teams.ceiling(2, block.effects)[0]:.1f} and" in report
    assert of.study_claims.claims_markdown(of.study_claims.claims(block.measured)) in report
    # the first two trials are the starting points: the default person, then the shipped fit
    study = of.open_study(out, settings)
    starts = [t.params for t in study.trials[:2]]
    assert starts[1] == pytest.approx(of._within_space(of.load_population(of.FITTED_POPULATION)))
    # a larger budget continues the same search; another experiment in the same --out is refused
    again = of.calibrate(out, of.Settings(budget=3, finalists=2, **small), 1)
    assert again.trials == 3
    with pytest.raises(ValueError, match="another experiment"):
        of.open_study(out, of.Settings(budget=3, participants=4))


def test_a_new_search_starts_without_a_shipped_fit_from_an_older_operator(
    tmp_path, monkeypatch
) -> None:
    """After a trait is added, the shipped fit lacks it and `hcss plan` refuses it; the
    re-fit that replaces it must still start (from the default person alone), not fail."""
    old = json.loads(of.FITTED_POPULATION.read_text(encoding="utf-8"))
    del old["median"]["hasten_prob"]
    shipped = tmp_path / "study-teams-population.json"
    shipped.write_text(json.dumps(old), encoding="utf-8")
    monkeypatch.setattr(of, "FITTED_POPULATION", shipped)
    study = of.open_study(tmp_path / "operators", of.Settings(budget=1, participants=2))
    assert len(study.trials) == 1  # the default person, queued


def test_the_fit_is_the_finalist_best_judged_on_the_selection_block(tmp_path) -> None:
    """The search's best `finalists` trials are judged again on a block of their own, and
    the least loss there is the fit, whatever the search's own order."""
    settings = of.Settings(
        budget=3, participants=2, validation_participants=2, selection_participants=3, finalists=2
    )
    result = of.calibrate(tmp_path / "operators", settings, workers=1)
    study = of.open_study(tmp_path / "operators", settings)
    by_search = sorted(study.trials, key=lambda t: t.value)
    best = [t.number for t in by_search[:2]]
    # the best two, then the shipped fit (trial 1, the first person after the default) if
    # it is not among them
    assert [f.trial for f in result.finalists] == best + ([1] if 1 not in best else [])
    for finalist in result.finalists:  # each judged on the selection block, as evaluate does
        again = of.evaluate(finalist.population, 3, of.SELECTION_BLOCK)
        assert finalist.selection_loss == pytest.approx(again.loss)
    chosen = min(result.finalists, key=lambda f: f.selection_loss)
    assert result.fit == chosen.population and result.search_loss == chosen.search_loss
    assert of.SELECTION_BLOCK not in (of.FIT_BLOCK, *of.VALIDATION_BLOCKS)
    report = (tmp_path / "operators" / "report.md").read_text(encoding="utf-8")
    assert f"judged again on block {of.SELECTION_BLOCK}" in report


def test_queued_starting_points_are_not_counted_as_trials_done(tmp_path) -> None:
    """A new search queues its starting points; the progress bar starts from the trials
    done, so a 300-trial search ends at 300 of 300, not 302."""
    settings = of.Settings(budget=2, participants=2)
    study = of.open_study(tmp_path / "operators", settings)
    assert len(study.trials) >= 2  # the default person and the shipped fit, queued
    assert of.trials_done(study) == 0
    of.search(study, settings, workers=1)
    assert of.trials_done(study) == 2


def test_a_search_starts_from_the_persons_given_and_a_resume_must_name_the_same(tmp_path) -> None:
    """`--start FILE`: after the default person the search runs the persons the file
    names, in its order and instead of the shipped fit; a value a person does not name is
    the shipped fit's. A resume with other starting persons is another search."""
    shipped = of._within_space(of.load_population(of.FITTED_POPULATION))
    starts_file = tmp_path / "starts.json"
    full = {name: (low + high) / 2 for name, (low, high, _log) in of.SEARCH_SPACE.items()}
    starts_file.write_text(json.dumps([{"abandon_gap": 0.09}, full]), encoding="utf-8")
    starts = of.load_starts(starts_file)
    assert starts == (shipped | {"abandon_gap": 0.09}, full)
    out = tmp_path / "operators"
    settings = of.Settings(budget=1, participants=2, starts=starts)
    study = of.open_study(out, settings)
    queued = [t.system_attrs["fixed_params"] for t in study.trials]  # as optuna enqueues
    assert queued[1:] == [pytest.approx(s) for s in starts]
    assert queued[0] == pytest.approx(of._within_space(of.Population()))
    with pytest.raises(ValueError, match="another experiment"):
        of.open_study(out, of.Settings(budget=1, participants=2, starts=starts[:1]))
    with pytest.raises(ValueError, match="another experiment"):
        of.open_study(out, of.Settings(budget=1, participants=2))
    assert len(of.open_study(out, settings).trials) == 3  # the same search: nothing re-queued


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("not json", "not a readable JSON file"),
        ("{}", "non-empty list"),
        ("[]", "non-empty list"),
        ("[3]", "person 1: not an object"),
        ('[{"abandon_gap": 0.09}, {}]', "person 2: not an object"),
        ('[{"abandon_gapp": 0.09}]', "not a search value: abandon_gapp"),
        ('[{"probe_ready_s": 2}]', "not a search value: probe_ready_s"),
        ('[{"abandon_gap": "0.09"}]', "abandon_gap must be a number"),
        ('[{"abandon_gap": true}]', "abandon_gap must be a number"),
        ('[{"abandon_gap": null}]', "abandon_gap must be a number"),
        ('[{"abandon_gap": NaN}]', "outside its search range"),
        ('[{"abandon_gap": 1e999}]', "outside its search range"),
        ('[{"abandon_gap": 0.5}]', "abandon_gap 0.5 is outside its search range 0.02-0.3"),
        ('[{"decide_support": 0.2}]', "outside its search range"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        ('[{"abandon_gap": 0.09}]' + " " * (1 << 20), "larger than 1 MiB"),
        ('[{"abandon_gap\u0000": 0.09}]', "not a readable JSON file"),  # a raw NUL
        (r'[{"abandon_gap\u0000": 0.09}]', "not a search value: abandon_gap"),  # JSON's escape
        (b"\xff\xfe[]", "not a readable JSON file"),
    ],
)
def test_a_bad_start_file_is_a_usage_error_that_writes_nothing(tmp_path, text, said) -> None:
    from click.testing import CliRunner

    from hcss.cli import main

    starts_file = tmp_path / "starts.json"
    if isinstance(text, bytes):
        starts_file.write_bytes(text)
    else:
        starts_file.write_text(text, encoding="utf-8")
    out = tmp_path / "operators"
    args = ["simulate", "calibrate", "--to", "study-teams", "--participants", "2"]
    result = CliRunner().invoke(
        main, [*args, "--budget", "1", "--start", str(starts_file), "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert "--start" in result.output and said in " ".join(result.output.split())
    assert "Traceback" not in result.output
    assert not out.exists()


def test_start_is_refused_for_the_models_calibrations_and_a_missing_file_is_named(tmp_path) -> None:
    from click.testing import CliRunner

    from hcss.cli import main

    starts_file = tmp_path / "starts.json"
    starts_file.write_text('[{"abandon_gap": 0.09}]', encoding="utf-8")
    out = tmp_path / "calibration"
    for to in ("published", "study"):
        result = CliRunner().invoke(
            main,
            ["simulate", "calibrate", "--to", to, "--start", str(starts_file), "--out", str(out)],
        )
        assert result.exit_code == 2 and "--to study-teams only" in result.output, result.output
    missing = tmp_path / "nowhere.json"
    result = CliRunner().invoke(
        main,
        [
            "simulate",
            "calibrate",
            "--to",
            "study-teams",
            "--start",
            str(missing),
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 2 and "nowhere.json" in result.output, result.output
    # a device is not a file of persons: refused at once, not read for ever
    result = CliRunner().invoke(
        main,
        ["simulate", "calibrate", "--to", "study-teams", "--start", "/dev/zero", "--out", str(out)],
    )
    assert result.exit_code == 2 and "not a regular file" in result.output, result.output
    assert not out.exists()


def test_the_shipped_fits_starting_file_names_every_search_value() -> None:
    """docs/synthetic-operators.md gives the shipped fit's command with
    `--start hcss/experiments/study-teams-starts.json`: for that search to come out the
    same whatever hcss ships later, each person in it must name every search value."""
    path = of.FITTED_POPULATION.with_name("study-teams-starts.json")
    named = json.loads(path.read_text(encoding="utf-8"))
    assert all(set(person) == set(of.SEARCH_SPACE) for person in named)
    assert [dict(p) for p in of.load_starts(path)] == named


def test_a_started_person_is_judged_on_the_selection_block_whatever_its_search_loss(
    tmp_path,
) -> None:
    """A search replaces the person it started from only with one that does better on the
    selection block: a started person far from the best by search loss is still a
    finalist, and the default person is not."""
    idle = {
        "glance_interval_s": 10.0,
        "investigate_prob": 0.02,
        "stalled_investigate_prob": 0.05,
        "decide_prob": 0.02,
        "hasten_prob": 0.005,
    }
    starts_file = tmp_path / "starts.json"
    starts_file.write_text(json.dumps([idle]), encoding="utf-8")
    settings = of.Settings(
        budget=4,
        participants=2,
        validation_participants=2,
        selection_participants=2,
        finalists=1,
        starts=of.load_starts(starts_file),
    )
    result = of.calibrate(tmp_path / "operators", settings, workers=1)
    study = of.open_study(tmp_path / "operators", settings)
    best = min(study.trials, key=lambda t: t.value)
    assert best.number != 1  # the idle person (trial 1) is not the search's best
    assert [f.trial for f in result.finalists] == [best.number, 1]
    idle_finalist = result.finalists[1]
    again = of.evaluate(idle_finalist.population, 2, of.SELECTION_BLOCK)
    assert idle_finalist.selection_loss == pytest.approx(again.loss)
    # the report counts what it judged: the search's best, then the started person, marked
    report = (tmp_path / "operators" / "report.md").read_text(encoding="utf-8")
    assert "## The search's best 1 and the persons it started from, judged again" in report
    assert f"| {best.number} | " in report and "| 1 (started) | " in report
