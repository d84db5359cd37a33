"""Experimenter accounts: `hcss admin create`, the first login printed by `hcss serve`, hashing."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from hcss.cli import main
from hcss.platform.console.accounts import FIRST_USERNAME, ensure_first_login
from hcss.platform.models import Experimenter
from tests.support.console import sign_in


@pytest.fixture
def cli(database_url, monkeypatch):
    """The `hcss` command on the test database."""
    monkeypatch.setenv("DATABASE_URL", database_url)
    return lambda *args, **options: CliRunner().invoke(main, list(args), **options)


def _usernames(app) -> list[str]:
    with app.extensions["hcss_db"].session_scope() as session:
        return list(session.scalars(select(Experimenter.username).order_by(Experimenter.id)))


def test_admin_create_makes_an_account_that_can_sign_in(app, cli) -> None:
    result = cli("admin", "create", "--username", "bob", "--password", "a long secret")
    assert result.exit_code == 0, result.output
    assert _usernames(app) == ["bob"]
    with app.extensions["hcss_db"].session_scope() as session:
        stored = session.scalars(select(Experimenter)).one().password_hash
    assert "a long secret" not in stored and stored.startswith("$argon2")
    assert sign_in(app.test_client(), "bob", "a long secret").status_code == 302


def test_admin_create_prompts_for_the_password_twice(app, cli) -> None:
    result = cli(
        "admin", "create", "--username", "carol", input="prompted secret\nprompted secret\n"
    )
    assert result.exit_code == 0, result.output
    assert "prompted secret" not in result.output
    assert sign_in(app.test_client(), "carol", "prompted secret").status_code == 302


def test_admin_create_refuses_a_taken_name_and_a_short_password(app, cli) -> None:
    assert cli("admin", "create", "--username", "bob", "--password", "a long secret").exit_code == 0
    again = cli("admin", "create", "--username", "bob", "--password", "another secret")
    assert again.exit_code != 0 and "already exists" in again.output
    short = cli("admin", "create", "--username", "dave", "--password", "short")
    assert short.exit_code != 0 and "at least 8 characters" in short.output
    assert _usernames(app) == ["bob"]
    assert sign_in(app.test_client(), "bob", "another secret").status_code == 401


def test_admin_create_on_an_unmigrated_database_says_what_to_do(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'empty.sqlite3'}")
    result = CliRunner().invoke(
        main, ["admin", "create", "--username", "x", "--password", "12345678"]
    )
    assert result.exit_code != 0 and "hcss db upgrade" in result.output


def test_first_serve_prints_one_login_and_later_serves_none(app, capsys) -> None:
    made = ensure_first_login(app)
    assert made is not None
    username, password = made
    printed = capsys.readouterr().out
    assert username == FIRST_USERNAME and password in printed
    assert sign_in(app.test_client(), username, password).status_code == 302
    assert ensure_first_login(app) is None
    assert capsys.readouterr().out == ""
    assert _usernames(app) == [FIRST_USERNAME]


def test_two_processes_starting_at_once_make_one_first_login(app, monkeypatch, capsys) -> None:
    """`--cluster` processes on several hosts start together on a new database: both count
    no experimenter, both make the first login, and the slower one must serve on (the
    other printed the login), not die of the unique username at start."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from hcss.platform.console import accounts

    both_counted = threading.Barrier(2, timeout=10)
    make = accounts.create_experimenter

    def make_after_both_counted(*args, **kwargs):
        both_counted.wait()
        return make(*args, **kwargs)

    monkeypatch.setattr(accounts, "create_experimenter", make_after_both_counted)
    with ThreadPoolExecutor(2) as starts:  # .result() raises what would end a process
        both = [starts.submit(ensure_first_login, app) for _ in range(2)]
        made = [start.result(timeout=30) for start in both]
    logins = [m for m in made if m is not None]
    assert len(made) == 2 and len(logins) == 1
    assert _usernames(app) == [FIRST_USERNAME]
    out, err = capsys.readouterr()
    assert out.count("first console login") == 1
    assert "hcss db upgrade" not in err  # the loser has nothing to fix
