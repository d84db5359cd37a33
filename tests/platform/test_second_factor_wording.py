"""What the shell's second-factor enrolment prints is what it gives (a secret and an
otpauth:// link, no picture), and the README tells an experimenter the factor exists."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from tests.support.console import USERNAME

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_enrolment_prints_no_promise_of_a_qr_code(app, experimenter, monkeypatch) -> None:
    from hcss.cli import main as cli

    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    result = CliRunner().invoke(cli, ["admin", "second-factor", USERNAME])
    assert result.exit_code == 0, result.output
    assert re.search(r"otpauth://totp/\S+", result.output)
    assert "QR" not in result.output  # nothing here draws one


def test_the_readme_names_the_second_factor() -> None:
    text = README.read_text(encoding="utf-8")
    assert "hcss admin second-factor" in text
