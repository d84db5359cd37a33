"""A participant's request for a trial another process holds is forwarded there, through nginx.

A request reaches a process that does not hold its trial when nginx passed it
on (the holder answered "busy", or did not answer in time) or when the trial
was taken over while its home was down. Asking for the trial then would move
it between two live processes, closing streams and stopping its clock, and
the next request would move it back (issue 41: one retried request, two
moves). Instead the process answers with ``X-Accel-Redirect: @hcss_<address>``,
the holder's address; nginx (`hcss deploy nginx` writes a named location per
member) sends the same request, method, headers and body, to that member,
and the participant gets the holder's answer. The process that forwarded has
written nothing (`HostedElsewhere` is raised before anything is applied), so
an unkeyed command is forwarded as safely as a keyed one.

Only what nginx marks forwardable is forwarded (the header `X-Hcss-Forward:
1`, set on a request's first pass and cleared on a forwarded one): a client
talking to a process directly, and a forwarded request that meets a holder
that has just let the trial go, get the 503 the page retries, never a loop.
The holder's address must be one of the group's members (HCSS_GROUP), for
which nginx has a location.
"""

from __future__ import annotations

from flask import Response, current_app, request
from werkzeug.exceptions import HTTPException

from hcss.platform.live.leases import HostedElsewhere
from hcss.platform.live.placement import address_of

#: Set to "1" by nginx on a request's first pass; a forwarded request carries it empty.
FORWARD_HEADER = "X-Hcss-Forward"


def location(address: str, *, stream: bool) -> str:
    """nginx's named location that sends a request to the member at `address`."""
    return f"@hcss_{address}{'_stream' if stream else ''}"


def forwarded(error: HTTPException) -> Response | None:
    """The answer that has nginx send this request to the trial's holder; None when the
    error is not a trial held by another member, or the request cannot be forwarded."""
    if not isinstance(error, HostedElsewhere) or not error.owner:
        return None
    if request.headers.get(FORWARD_HEADER) != "1":
        return None
    address = address_of(error.owner)
    if address not in (current_app.config.get("GROUP_MEMBERS") or ()):
        return None
    response = Response(status=200)
    response.headers["X-Accel-Redirect"] = location(
        address, stream=request.path.endswith("/stream")
    )
    return response
