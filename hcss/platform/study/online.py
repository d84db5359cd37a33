"""Online recruitment: the study file's `[online]` table and the recruiter's URL parameters.

A recruitment site (Prolific, SONA, MTurk) sends each person to one study
link and appends its own ids to the URL. Those ids are the only thing that
tells a returning person from a new one, so they are read here once, checked
hard (they are typed by strangers and by misconfigured sites alike), and
turned into one `Recruit` that the enrolment stores. Nothing here touches the
database.
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Mapping
from dataclasses import dataclass
from string import Formatter
from typing import Annotated
from urllib.parse import quote, urlsplit

from pydantic import (
    ConfigDict,
    Field,
    StrictBool,
    StrictInt,
    StrictStr,
    ValidationInfo,
    field_validator,
)
from pydantic.dataclasses import dataclass as pydantic_dataclass
from werkzeug.datastructures import MultiDict

#: Longest accepted recruitment parameter value (Prolific ids are 24 characters).
MAX_VALUE_LENGTH = 128
#: What a recruitment id may hold. Prolific ids are hex, SONA codes digits, MTurk
#: ids upper-case letters and digits; anything else (NUL, controls, spaces, a
#: mangled percent-escape that Werkzeug leaves as "%FF") is refused, not stored.
ID_CHARACTERS = re.compile(r"[A-Za-z0-9._:@+\-]+")


class RecruitmentError(ValueError):
    """A study link the platform refuses; the message is shown to the visitor (a 4xx)."""


class HitPreview(RecruitmentError):
    """MTurk showing the HIT before a worker accepts it: a page, but no one to enrol."""


#: What MTurk puts in `assignmentId` while a worker previews a HIT.
MTURK_PREVIEW = "ASSIGNMENT_ID_NOT_AVAILABLE"
#: The parameter naming the MTurk server a HIT's answer is posted to (its `/mturk/externalSubmit`).
MTURK_SUBMIT_TO = "turkSubmitTo"
#: MTurk's two servers, production and sandbox: the only values `turkSubmitTo` takes
#: ("Mechanical Turk appends ... turkSubmitTo=https://www.mturk.com/", How Mechanical
#: Turk tasks are rendered; the sandbox's is https://workersandbox.mturk.com).
MTURK_SUBMIT_ORIGINS = ("https://www.mturk.com", "https://workersandbox.mturk.com")
#: Where the debrief's externalSubmit may go, redirects included: MTurk answers the post
#: with a redirect to another of its hosts (www.mturk.com sends workers on to
#: worker.mturk.com), and Chromium checks a form's CSP form-action on every redirect.
MTURK_FORM_ACTION = ("https://*.mturk.com",)
#: The pages that show a HIT's iframe: the worker site, the older www site and the sandbox.
MTURK_FRAME_ORIGINS = (
    "https://worker.mturk.com",
    "https://www.mturk.com",
    "https://workersandbox.mturk.com",
)


@dataclass(frozen=True)
class Source:
    """One recruitment site: the parameter naming the person, and its two context ids."""

    name: str
    id_parameter: str
    study_parameter: str | None = None
    session_parameter: str | None = None

    def parameters(self) -> tuple[str, ...]:
        names = (self.id_parameter, self.study_parameter, self.session_parameter)
        return tuple(name for name in names if name)


#: The sites whose parameters are recognised, in the order they are looked for.
SOURCES = (
    # Prolific's study URL: ?PROLIFIC_PID={{%PROLIFIC_PID%}}&STUDY_ID=...&SESSION_ID=...
    Source("prolific", "PROLIFIC_PID", "STUDY_ID", "SESSION_ID"),
    # SONA's "study URL" with %SURVEY_CODE% appended as ?id=%SURVEY_CODE%.
    Source("sona", "id"),
    # MTurk external question: ?workerId=...&assignmentId=...&hitId=...
    Source("mturk", "workerId", "hitId", "assignmentId"),
)
ANONYMOUS = "link"  # a visit that brought no recruitment id


@dataclass(frozen=True)
class Recruit:
    """Who came through the study link: the site, its id of the person, and its context."""

    source: str
    recruitment_id: str | None
    recruiter_study_id: str | None = None
    recruiter_session_id: str | None = None
    #: MTurk's `turkSubmitTo`, an origin of the study's `mturk_origins` (else None).
    submit_to: str | None = None


def origin_of(url: str) -> str | None:
    """`scheme://host[:port]` of an http(s) URL with nothing after it but `/`, else None."""
    parts = urlsplit(url)
    if parts.scheme not in ("https", "http") or not parts.netloc or "@" in parts.netloc:
        return None
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        return None
    return f"{parts.scheme}://{parts.netloc}".lower()


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


#: The recruitment ids a completion, screen-out or return URL may name as `{placeholder}`.
PLACEHOLDERS = tuple(name for source in SOURCES for name in source.parameters())


def placeholder_problem(url: str) -> str | None:
    """Why a URL's `{placeholders}` cannot be filled, or None; `{{` and `}}` are literal braces."""
    try:
        fields = [(name, spec, conversion) for _, name, spec, conversion in Formatter().parse(url)]
    except ValueError as error:
        return f"has unbalanced braces ({error}); write a literal brace as {{{{ or }}}}"
    for name, spec, conversion in fields:
        if name is None:
            continue
        if name not in PLACEHOLDERS:
            known = ", ".join("{" + known + "}" for known in PLACEHOLDERS)
            return f"has the unknown placeholder {{{name}}}; the known ones are {known}"
        if spec or conversion:
            return f"gives the placeholder {{{name}}} a format; write it bare"
    return None


def fill_placeholders(url: str, ids: Mapping[str, str]) -> str:
    """The URL with each `{placeholder}` replaced by that id, URL-encoded ("" when absent)."""
    return "".join(
        literal + ("" if name is None else quote(ids.get(name, ""), safe=""))
        for literal, name, _, _ in Formatter().parse(url)
    )


@pydantic_dataclass(frozen=True, config=ConfigDict(extra="forbid"))
class OnlineSettings:
    """The study file's `[online]` table; without it the study has no public link.

    Checked when built (a study file is read through it), because the code and
    URL are shown to every participant who finishes.
    """

    link: StrictBool = False
    anonymous: StrictBool = False
    completion_code: StrictStr = ""
    completion_url: StrictStr = ""
    redirect: StrictBool = False
    # For a visitor turned away by `[requirements]` or who declines consent.
    screenout_code: StrictStr = ""
    screenout_url: StrictStr = ""
    # For a visitor who should return the submission rather than be screened out or paid:
    # the study was full, they declined consent, or the experimenter ended their session;
    # the default of the three outcomes below, each of which may have its own.
    return_code: StrictStr = ""
    return_url: StrictStr = ""
    # Declined consent (without these nor a return code or URL: the screen-out's).
    declined_code: StrictStr = ""
    declined_url: StrictStr = ""
    # Came while the study was full.
    full_code: StrictStr = ""
    full_url: StrictStr = ""
    # The experimenter ended the session (a technical fault, a participant who asked):
    # returned by default; `ended_paid = true` pays them (the completion code and URL
    # unless `ended_code` or `ended_url` is given).
    ended_code: StrictStr = ""
    ended_url: StrictStr = ""
    ended_paid: StrictBool = False
    # For a participant timed out by `[timeouts]`.
    timeout_code: StrictStr = ""
    timeout_url: StrictStr = ""
    # MTurk (ExternalQuestion): the join page may be framed by MTurk, and the debrief
    # posts the assignment to `turkSubmitTo`/mturk/externalSubmit. `mturk_origins`
    # replaces MTurk's origins (both for framing and for turkSubmitTo) with others,
    # such as a stand-in for MTurk on this machine in a test: https, or http on loopback.
    mturk: StrictBool = False
    mturk_origins: list[StrictStr] = Field(default_factory=list)
    # The recruitment target: the link closes ("study full") once this many real
    # participants are in progress or completed (0: no target), or once every
    # counterbalancing cell holds `cell_target` of them.
    target: Annotated[StrictInt, Field(ge=0)] = 0
    cell_target: Annotated[StrictInt, Field(ge=0)] = 0

    @field_validator(
        "completion_code",
        "screenout_code",
        "return_code",
        "declined_code",
        "full_code",
        "ended_code",
        "timeout_code",
    )
    @classmethod
    def _printable_code(cls, code: str) -> str:
        if code and not (code.isascii() and code.isprintable() and len(code) <= 64):
            raise ValueError("is up to 64 printable ASCII characters")
        return code

    @field_validator(
        "completion_url",
        "screenout_url",
        "return_url",
        "declined_url",
        "full_url",
        "ended_url",
        "timeout_url",
    )
    @classmethod
    def _web_address(cls, url: str) -> str:
        if url and (urlsplit(url).scheme not in ("https", "http") or not urlsplit(url).netloc):
            raise ValueError("must be an http(s) URL")
        problem = placeholder_problem(url)
        if problem:
            raise ValueError(problem)
        if "{" in urlsplit(url).netloc:
            raise ValueError("may hold placeholders only after the host")
        return url

    @field_validator("mturk_origins")
    @classmethod
    def _mturk_stand_in(cls, origins: list[str]) -> list[str]:
        normal = []
        for url in origins:
            origin = origin_of(url)
            if origin is None:
                raise ValueError(f"{url!r} is not an origin (scheme://host[:port])")
            parts = urlsplit(origin)
            if parts.scheme != "https" and not _loopback(parts.hostname or ""):
                raise ValueError(f"{url!r}: an origin off this machine must be https")
            normal.append(origin)
        return normal

    @property
    def mturk_frame_origins(self) -> tuple[str, ...]:
        """Who may frame the study link: MTurk's pages (or the stand-ins); none without MTurk."""
        if not self.mturk:
            return ()
        return tuple(self.mturk_origins) or MTURK_FRAME_ORIGINS

    @property
    def mturk_submit_origins(self) -> tuple[str, ...]:
        """The `turkSubmitTo` values accepted: MTurk's two servers (or the stand-ins)."""
        if not self.mturk:
            return ()
        return tuple(self.mturk_origins) or MTURK_SUBMIT_ORIGINS

    @property
    def mturk_form_action(self) -> tuple[str, ...]:
        """Where the debrief's externalSubmit and MTurk's redirects after it may go: any
        MTurk host (or every stand-in the study names)."""
        if not self.mturk:
            return ()
        return tuple(self.mturk_origins) or MTURK_FORM_ACTION

    @field_validator("redirect")
    @classmethod
    def _redirect_has_a_target(cls, redirect: bool, info: ValidationInfo) -> bool:
        if redirect and not info.data.get("completion_url"):
            raise ValueError("needs `online.completion_url`")
        return redirect


def _value(args: MultiDict[str, str], name: str) -> str | None:
    """One recruitment parameter, or None when absent; RecruitmentError when unusable.

    Names are matched without regard to case (`prolific_pid` is `PROLIFIC_PID`):
    a site or an experimenter that retypes the link must not lose the id.
    """
    values = [value for key in args if key.lower() == name.lower() for value in args.getlist(key)]
    if not values:
        return None
    if len(values) > 1:
        raise RecruitmentError(f"The link gives {name} more than once.")
    value = values[0]
    if not value:
        raise RecruitmentError(f"The link's {name} is empty.")
    if len(value) > MAX_VALUE_LENGTH:
        raise RecruitmentError(f"The link's {name} is longer than {MAX_VALUE_LENGTH} characters.")
    if "{{%" in value or (value.startswith("%") and value.endswith("%")):
        # The recruitment site sent its placeholder instead of filling it in.
        raise RecruitmentError(
            f"The link's {name} was not filled in by the recruitment site ({value})."
        )
    if not ID_CHARACTERS.fullmatch(value):
        raise RecruitmentError(f"The link's {name} holds characters an id cannot have.")
    if not value.strip("."):
        # A completion URL may name the id in its path (/s/{PROLIFIC_PID}/...): "." or ".."
        # there is a path step, and the participant would be sent to another page.
        raise RecruitmentError(f"The link's {name} is only dots, which no id is.")
    return value


def recruit_from(args: MultiDict[str, str]) -> Recruit:
    """The recruiter's ids in a study link's query string (other parameters are ignored).

    Every recognised parameter is checked, even those of a site not used, so a
    hostile or mangled value is refused rather than silently dropped.
    """
    found = {
        source.name: {name: _value(args, name) for name in source.parameters()}
        for source in SOURCES
    }
    if found["mturk"]["assignmentId"] == MTURK_PREVIEW:
        raise HitPreview("Please accept the HIT first; the study opens once you have.")
    for source in SOURCES:
        values = found[source.name]
        if values[source.id_parameter] is not None:
            return Recruit(
                source=source.name,
                recruitment_id=values[source.id_parameter],
                recruiter_study_id=values.get(source.study_parameter or ""),
                recruiter_session_id=values.get(source.session_parameter or ""),
                submit_to=_submit_to(args) if source.name == "mturk" else None,
            )
    return Recruit(source=ANONYMOUS, recruitment_id=None)


def _submit_to(args: MultiDict[str, str]) -> str | None:
    """MTurk's `turkSubmitTo` as an origin; which origins a study accepts is checked by the caller."""
    values = args.getlist(MTURK_SUBMIT_TO)
    if not values:
        return None
    if len(values) > 1:
        raise RecruitmentError(f"The link gives {MTURK_SUBMIT_TO} more than once.")
    origin = origin_of(values[0]) if len(values[0]) <= MAX_VALUE_LENGTH else None
    if origin is None:
        raise RecruitmentError(f"The link's {MTURK_SUBMIT_TO} is not a web address.")
    return origin


def check_submit_to(recruit: Recruit, accepted: tuple[str, ...]) -> None:
    """RecruitmentError unless an MTurk visit's `turkSubmitTo` is one of the study's MTurk servers.

    The debrief posts the assignment there, so it is never taken from the link
    unchecked: an address of anyone's choosing would receive the worker's ids.
    """
    if recruit.source != "mturk":
        return
    if not accepted:
        raise RecruitmentError("This study does not take part in MTurk.")
    if recruit.submit_to is None:
        raise RecruitmentError(f"The link lacks MTurk's {MTURK_SUBMIT_TO}; open the HIT on MTurk.")
    if recruit.submit_to not in accepted:
        raise RecruitmentError(f"The link's {MTURK_SUBMIT_TO} is not MTurk ({recruit.submit_to}).")


def recruitment_parameters(recruit: Recruit) -> dict[str, str]:
    """The recruiter's ids as the site's own parameters, to carry them through a form."""
    source = next((s for s in SOURCES if s.name == recruit.source), None)
    if source is None or recruit.recruitment_id is None:
        return {}
    values = {
        source.id_parameter: recruit.recruitment_id,
        source.study_parameter: recruit.recruiter_study_id,
        source.session_parameter: recruit.recruiter_session_id,
    }
    if recruit.submit_to:
        values[MTURK_SUBMIT_TO] = recruit.submit_to
    return {name: value for name, value in values.items() if name and value}
