"""What the shell's second-factor enrolment prints is what it gives (a secret and an
otpauth:// link, no picture), and the README tells an experimenter the factor exists."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from tests.support.console import USERNAME

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_enrolment_prints_no_promise_of_a_qr_code(app, experimenter, monkeypatch) -> None:
    """The words promise no picture. The secret is base32, so it may hold the letters QR
    itself (about one enrolment in 30 did, and failed this test): here it always does."""
    import pyotp

    from hcss.cli import main as cli

    secret = "QR" + pyotp.random_base32()[2:]
    monkeypatch.setattr(pyotp, "random_base32", lambda *args, **kwargs: secret)
    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    result = CliRunner().invoke(cli, ["admin", "second-factor", USERNAME])
    assert result.exit_code == 0, result.output
    assert secret in result.output and re.search(r"otpauth://totp/\S+", result.output)
    words = re.sub(r"otpauth://\S+", "", result.output).replace(secret, "")
    assert "QR" not in words  # nothing here draws one


def test_the_readme_names_the_second_factor() -> None:
    text = README.read_text(encoding="utf-8")
    assert "hcss admin second-factor" in text
