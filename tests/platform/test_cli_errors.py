"""Platform commands on a database that was never migrated say what to do, without a traceback."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from hcss.cli import main
from tests.support.trials import STUDY_TRIAL_S


@pytest.mark.parametrize(
    "arguments",
    [
        ["demo-trial"],
        ["admin", "create", "--username", "x", "--password", "12345678"],
    ],
)
def test_commands_on_an_unmigrated_database_point_to_db_upgrade(arguments, tmp_path, monkeypatch):
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'empty.sqlite3'}")
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == 1
    assert "hcss db upgrade" in result.output and "Traceback" not in result.output


def test_live_trials_have_no_per_decision_cap(tmp_path):
    """Spec §2: a live trial has no 30-minute decision cap, only its own time limit."""
    from hcss.platform.db import Database
    from hcss.platform.live.trials import start_trial
    from hcss.platform.models import Participant
    from hcss.simulation import Params

    database = Database(f"sqlite:///{tmp_path / 'live.sqlite3'}")
    database.create_all()
    with database.session_scope() as session:
        participant = Participant(is_demo=True)
        session.add(participant)
        session.flush()
        trial = start_trial(
            session, participant, kind="trial", model="M1", seed=3, duration_s=STUDY_TRIAL_S
        )
        assert Params.from_dict(trial.params).decision_timeout_s is None
    database.engine.dispose()
