"""`hcss study check FILE`: one clean line per problem (file:line, the key, the known keys),
exit 1; a clean file exits 0. A participant opening the link of a broken study file gets a
page that says so, and the server's terminal names the problem."""

from __future__ import annotations

import logging
import re
from pathlib import Path

from click.testing import CliRunner

from hcss.cli import main
from hcss.platform.study.files import study_text
from tests.support.recruitment import demo_variant


def _broken(directory: Path, name: str = "broken") -> Path:
    """The demo study with a misspelt key in [online] and a text where a number goes."""
    text = study_text("demo")[1].decode().replace('name = "demo"', f'name = "{name}"')
    text = text.replace("trial_s = 120.0", 'trial_s = "two minutes"')
    text = text.replace("[online]\n", '[online]\ncompeltion_code = "X1"\n')
    directory.mkdir(exist_ok=True)
    path = directory / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _line(path: Path, needle: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def test_study_check_prints_one_line_per_problem_and_exits_1(tmp_path) -> None:
    path = _broken(tmp_path / "studies")
    result = CliRunner().invoke(main, ["study", "check", str(path)])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 2, result.output
    typo, number = sorted(lines, key=lambda line: "compeltion" not in line)
    assert typo.startswith(f"{path}:{_line(path, 'compeltion_code')}: ")
    assert "unknown setting `online.compeltion_code`" in typo and "'completion_code'" in typo
    assert number.startswith(f"{path}:{_line(path, 'trial_s =')}: ")
    assert "timing.trial_s" in number


def test_study_check_names_a_toml_syntax_error_by_line(tmp_path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\ntitle = "unclosed\n', encoding="utf-8")
    result = CliRunner().invoke(main, ["study", "check", str(path)])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert re.fullmatch(rf"{re.escape(str(path))}:2: .+\n", result.output), result.output


def test_study_check_passes_a_good_file_and_refuses_a_missing_one(tmp_path) -> None:
    good = tmp_path / "demo.toml"
    good.write_bytes(study_text("demo")[1])
    result = CliRunner().invoke(main, ["study", "check", str(good)])
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{good}: ok")
    missing = CliRunner().invoke(main, ["study", "check", str(tmp_path / "nope.toml")])
    assert missing.exit_code != 0 and "Traceback" not in missing.output


def test_a_participant_opening_a_broken_study_is_told_and_the_server_logs_it(
    app, tmp_path, monkeypatch, caplog
) -> None:
    demo_variant(tmp_path / "studies", monkeypatch, "fine", {})  # sets HCSS_STUDIES
    path = _broken(tmp_path / "studies")
    with caplog.at_level(logging.WARNING):
        page = app.test_client().get("/join/broken?PROLIFIC_PID=p1&STUDY_ID=s&SESSION_ID=x")
    assert page.status_code == 503
    html = page.get_data(as_text=True)
    assert "There is no study at this link" not in html
    assert "cannot be opened at the moment" in html
    assert "compeltion" not in html  # the file's details are the experimenter's
    logged = [record.getMessage() for record in caplog.records]
    assert any(
        "broken" in line and f"{path.name}:{_line(path, 'compeltion_code')}" in line
        for line in logged
    ), logged
    missing = app.test_client().get("/join/nosuchstudy?PROLIFIC_PID=p1")
    assert missing.status_code == 404
    assert "There is no study at this link" in missing.get_data(as_text=True)
