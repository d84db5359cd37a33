"""Issue 30 §7: a closed test server writes into no one's descriptor.

Waitress' task threads wake its loop by writing b"x" (byte 120) into its
trigger pipe. The in-process servers closed the server (and so the pipe)
while a live stream's task still ran; when that stream ended, its wake-up went
into whatever had meanwhile been given the pipe's descriptor number, and a
fresh PostgreSQL connection of the next test read "invalid frontend message
type 120". Here the freed numbers go to files of the test's own, the stream
ends after the close, and the files must stay empty.
"""

from __future__ import annotations

import os
import time

from hcss.platform.live.client import TrialClient
from hcss.platform.live.trials import start_trial
from hcss.platform.models import Participant
from tests.support.study_server import study_server


def test_a_stream_ending_after_the_server_closed_writes_into_no_reused_descriptor(
    tmp_path,
) -> None:
    with study_server(tmp_path) as server:
        with server.app.app_context(), server.database.command_scope() as session:
            participant = Participant(is_demo=True, study="demo")
            session.add(participant)
            session.flush()
            trial = start_trial(session, participant, kind="trial", duration_s=10.0)
            token, duration_s = participant.token, trial.duration_s
        client = TrialClient(server.url, token)
        client.open_page()
        frames = client.frames()
        next(frames)  # the stream is open and has sent its first frame
        pipe = list(server.waitress.trigger._fds)

    # The freed descriptor numbers go to files of ours, the lowest first, as the
    # next test's database connection would get them.
    files = [tmp_path / f"descriptor-{n}" for n in range(32)]
    descriptors = [os.open(path, os.O_WRONLY | os.O_CREAT) for path in files]
    try:
        assert set(pipe) & set(descriptors), "the test needs the trigger's numbers reused"
        server.advance(duration_s + 5.0)  # the trial ends, and with it a stream still running
        time.sleep(0.5)
        frames.close()
        client.close()
        time.sleep(0.5)
    finally:
        for descriptor in descriptors:
            os.close(descriptor)
    written = {path.name: path.read_bytes() for path in files if path.stat().st_size}
    assert written == {}
