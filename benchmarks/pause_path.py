"""How deep a console pause goes: the functions, modules and return sites it passes through.

Issue 29 followed one pause of a live trial through the code by hand (50 stops
in 13 modules, 37 returns). This counts the same walk with `sys.settrace`: a
trial hosted by this process (SQLite, no runner thread), one
`console.sessions.change_participant_state(..., "pause")` traced, and of the package's
own code (hcss/, the models included, the libraries not) it reports

- stops: distinct functions entered (file, name, first line);
- modules: distinct files of those functions;
- returns: distinct places a function returned from (file, line).

Run: python -m benchmarks.pause_path (add PYTHONPATH=<another checkout> to count
that one's path with the same script).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from types import FrameType
from typing import Any


def main() -> None:
    import hcss
    from hcss.platform.app import create_app
    from hcss.platform.bots.participant import ManualClock
    from hcss.platform.console.interventions import change_participant_state
    from hcss.platform.live.trials import start_bot_trial
    from hcss.platform.models import Participant

    package = str(Path(hcss.__file__).parent)
    with tempfile.TemporaryDirectory() as folder:
        app = create_app(
            {
                "DATABASE_URL": f"sqlite:///{folder}/pause.sqlite3",
                "SECRET_KEY": "pause-path",
                "TESTING": True,
                "LIVE_RUNNER": False,
            }
        )
        database, runner = app.extensions["hcss_db"], app.extensions["hcss_runner"]
        database.create_all()
        runner.clock = ManualClock(1_000_000.0)
        with database.session_scope() as session:
            participant, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            participant_id, trial_id = participant.id, trial.id
        assert runner.host(trial_id) is not None
        runner.clock.now += 1.0
        with database.session_scope() as session:
            participant = session.get_one(Participant, participant_id)
            session.expunge(participant)

        functions: set[tuple[str, str, int]] = set()
        returns: set[tuple[str, int]] = set()

        def trace(frame: FrameType, event: str, _arg: Any) -> Any:
            if not frame.f_code.co_filename.startswith(package):
                return None
            code = frame.f_code
            if event == "call":
                functions.add((code.co_filename, code.co_name, code.co_firstlineno))
            elif event == "return":
                returns.add((code.co_filename, frame.f_lineno))
            return trace

        with app.app_context():
            sys.settrace(trace)
            try:
                change_participant_state(
                    database, app.extensions["hcss_live"], participant, None, "pause"
                )
            finally:
                sys.settrace(None)
        assert runner.loaded(trial_id) is not None
        modules = {file for file, _name, _line in functions}
        print(
            f"one console pause: {len(functions)} stops in {len(modules)} modules, "
            f"{len(returns)} returns"
        )
        for module in sorted(modules):
            names = sorted(name for file, name, _ in functions if file == module)
            print(f"  {Path(module).relative_to(package)}: {', '.join(names)}")
        database.engine.dispose()


if __name__ == "__main__":
    main()
