"""Issue 44 §3: a sign-in link's `next` holding CR/LF (or any control character) sends the
experimenter to a safe console page after a right password, never a 500 and never a header
of the link's choosing (a NUL is refused 400 before any page, hardening). werkzeug refuses a Location with a line break, so the redirect
raised; a link like that can be mailed to the lab."""

from __future__ import annotations

from urllib.parse import quote

import pytest

from tests.support.console import PASSWORD, USERNAME
from tests.support.trials import csrf_token_of

HOSTILE_NEXT = [
    "/console/\r\nSet-Cookie: planted=1",
    "/console/\nX-Injected: 1",
    "/console/\rX",
    "/console/\t/evil",
    "/console/\x7f",
    "/console/\x1b[31m",
    "/console/\u2028x",
]


@pytest.mark.parametrize("target", HOSTILE_NEXT)
def test_a_next_with_control_characters_redirects_to_the_console(app, experimenter, target):
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = "10.0.44.3"
    path = f"/console/login?next={quote(target, safe='')}"
    page = client.get(path)
    assert page.status_code == 200
    token = csrf_token_of(page.get_data(as_text=True))
    answer = client.post(
        path, data={"csrf_token": token, "username": USERNAME, "password": PASSWORD}
    )
    assert answer.status_code == 302, answer.status_code
    location = answer.headers["Location"]
    assert location.endswith("/console/"), location
    assert "planted" not in answer.headers.get("Set-Cookie", "")
    assert "X-Injected" not in answer.headers
    assert client.get(location).status_code == 200  # signed in


def test_a_plain_console_next_is_still_followed(app, experimenter) -> None:
    client = app.test_client()
    path = f"/console/login?next={quote('/console/links?codes=AB', safe='')}"
    token = csrf_token_of(client.get(path).get_data(as_text=True))
    answer = client.post(
        path, data={"csrf_token": token, "username": USERNAME, "password": PASSWORD}
    )
    assert answer.headers["Location"].endswith("/console/links?codes=AB")
