"""Study files: found in the user's directory before the bundled ones, and every
error names the file, the line and the setting (the schema is pydantic's)."""

from __future__ import annotations

from pathlib import Path

import pytest

from hcss.platform.study.files import STUDIES_ENV, StudyFileError, study_names, study_text
from hcss.platform.study.studyfile import load_study

DEMO = study_text("demo")[1].decode()


@pytest.fixture
def studies(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A user study directory, named by HCSS_STUDIES."""
    monkeypatch.setenv(STUDIES_ENV, str(tmp_path))
    return tmp_path


def _write(directory: Path, name: str, *replacements: tuple[str, str]) -> None:
    text = DEMO.replace('name = "demo"', f'name = "{name}"')
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new)
    (directory / f"{name}.toml").write_text(text)


def _line(name: str, directory: Path, start: str) -> int:
    lines = (directory / f"{name}.toml").read_text().splitlines()
    return next(i for i, line in enumerate(lines, 1) if line.startswith(start))


def test_a_user_study_is_loaded_listed_and_wins_over_a_bundled_one(studies: Path) -> None:
    _write(studies, "mine")
    _write(studies, "demo", ("trial_s = 120.0", "trial_s = 90.0"))
    assert load_study("mine").name == "mine"
    assert load_study("demo").timing.trial_s == 90.0
    assert {"demo", "mine", "original"} <= set(study_names())


def test_a_study_directory_that_does_not_exist_is_an_error(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv(STUDIES_ENV, str(tmp_path / "nowhere"))
    with pytest.raises(StudyFileError, match="HCSS_STUDIES=.*nowhere: no such directory"):
        load_study("demo")


@pytest.mark.parametrize(
    ("replacement", "line_start", "message"),
    [
        (
            ("trial_s = 120.0", "trial_s = -5.0"),
            "trial_s",
            r"`timing.trial_s` must be greater than 0",
        ),
        (
            ("practice_items = 1", "practice_items = true"),
            "practice_items",
            r"`mrt.practice_items` must be an integer, not bool",
        ),
        (
            ("break_s = 10.0", "brake_s = 10.0"),
            "brake_s",
            r"unknown setting `mrt.brake_s`; known: \['break_s'",
        ),
        (
            ('"screen_check"]', '"screen_chek"]'),
            "before",
            r"`sequence.before` unknown stage 'screen_chek'",
        ),
        (
            ("perception = 4", "perception = 40"),
            "perception",
            r"`probes.perception` must be 0 to 20",
        ),
        (
            ('constants.first_section_M3 = "easy"', 'constants.first_section_M3 = "hard"'),
            "constants.first_section_M3",
            r"cell 1: `first_section_M3` must be one of",
        ),
        (
            ('completion_code = "DEMO2026"', 'completion_code = "DÉMO"'),
            "completion_code",
            r"`online.completion_code` is up to 64 printable ASCII",
        ),
    ],
)
def test_an_error_names_the_file_the_line_and_the_setting(
    studies: Path, replacement: tuple[str, str], line_start: str, message: str
) -> None:
    _write(studies, "mine", replacement)
    line = _line("mine", studies, line_start)
    with pytest.raises(StudyFileError, match=rf"(?m)^mine\.toml:{line}: {message}"):
        load_study("mine")


def test_a_missing_table_and_every_other_error_are_all_reported(studies: Path) -> None:
    text = DEMO.split("[timing]")[0] + "[mrt]" + DEMO.split("[mrt]")[1]
    (studies / "mine.toml").write_text(text.replace("break_s = 10.0", "break_s = 0"))
    with pytest.raises(StudyFileError) as raised:
        load_study("mine")
    lines = str(raised.value).splitlines()
    assert "mine.toml: missing setting `timing`" in lines
    assert any(line.endswith("`mrt.break_s` must be greater than 0") for line in lines)


def test_a_file_that_is_not_toml_names_its_line(studies: Path) -> None:
    (studies / "mine.toml").write_text('name = "mine"\ntitle = \n')
    with pytest.raises(StudyFileError, match=r"mine\.toml: .*line 2"):
        load_study("mine")


def test_hcss_studies_names_the_directory_for_every_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`hcss --studies DIR` sets HCSS_STUDIES, so the command (and servers it starts) see it."""
    from click.testing import CliRunner

    from hcss.cli import main

    monkeypatch.delenv(STUDIES_ENV, raising=False)  # restored after: the CLI sets it
    _write(tmp_path, "mine")
    database = f"sqlite:///{tmp_path / 'x.sqlite3'}"
    result = CliRunner().invoke(
        main,
        ["--studies", str(tmp_path), "bots", "--study", "nope", "--database-url", database],
    )
    assert result.exit_code == 2 and "'mine'" in result.output, result.output
    missing = CliRunner().invoke(main, ["--studies", str(tmp_path / "nowhere"), "bots"])
    assert missing.exit_code == 2 and "does not exist" in missing.output
