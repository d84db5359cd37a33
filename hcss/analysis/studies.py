"""Which study files the analysed participants ran, and refusing to pool them by accident.

One server runs several study files: the protocol, and a demo with 2-minute
trials for walk-throughs whose participants come through the same kind of
link and are not flagged. Their data must never land in one analysis
unnoticed. The export's participants table names each participant's study
and the digest of its file; the analysis keeps one study when asked
(`--study`), refuses to pool different files unless asked (`--pool-studies`),
and the report names every study it includes.

A link that was never opened ran no study file: the export lists it as
``not_started`` (older exports as ``in_progress`` with neither digest nor
cell), with the study it was created for. Such a link is no participant of
any study: it is set aside before anything is counted (`set_aside_never_opened`),
so it neither counts as a second study file nor enters the sample, and the
report says how many there were.

A trial started outside the study flow (`hcss demo-trial`) has a participant of the
study but no enrolment, so no digest. It ran that study's trial settings and no file
of its own: it is counted with its study's one file (and said to be outside the flow),
never as a second file.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd


class StudyPoolingError(ValueError):
    """Participants of different study files, with no permission to pool them."""


@dataclass(frozen=True)
class StudyFile:
    """A study file the analysed participants ran: its name, digest and how many."""

    name: str
    digest: str
    participants: int
    outside_flow: int = 0  # of `participants`, those with a trial outside the study flow

    def label(self) -> str:
        """``demo (file 7dbeb0c2a4f1…): 4 participants``: the study's name, the start of
        the sha256 of the file they ran (two digests: the file was changed mid-study)."""
        digest = (
            f"file {self.digest[:12]}…" if self.digest else "file not identified by this export"
        )
        plural = "" if self.participants == 1 else "s"
        label = f"{self.name} ({digest}): {self.participants} participant{plural}"
        if self.outside_flow:
            ran = "ran a trial" if self.outside_flow == 1 else "ran trials"
            label += (
                f" ({self.outside_flow} participant {ran} outside the study flow, "
                "e.g. hcss demo-trial, and enrolled in no file)"
            )
        return label


#: The export's status of a participant whose link was never opened.
NOT_STARTED = "not_started"


def never_opened(participants: pd.DataFrame) -> pd.Series:
    """True for each row that is a link nobody opened: status ``not_started``, or, in an
    export from before that status, ``in_progress`` with no study digest and no cell."""
    status = _column(participants, "status")
    older = (
        (status == "in_progress")
        & (_column(participants, "study_digest") == "")
        & (_column(participants, "cell") == "")
        & ("study_digest" in participants.columns)
        & (_column(participants, "model_order") == "")
    )
    return (status == NOT_STARTED) | older


def set_aside_never_opened(participants: pd.DataFrame) -> tuple[pd.DataFrame, int]:
    """The participants who opened their link, and how many links were never opened."""
    if participants.empty:
        return participants, 0
    unopened = never_opened(participants)
    return participants[~unopened], int(unopened.sum())


def studies_line(files: tuple[StudyFile, ...], unopened: int) -> str:
    """The report's "Study files analysed" sentence (empty when there is nothing to say)."""
    parts = []
    if files:
        parts.append(
            "Study files analysed (the study's name and the start of the sha256 digest of "
            "the file its participants ran): " + "; ".join(file.label() for file in files) + "."
        )
    if unopened:
        links = "link was" if unopened == 1 else "links were"
        parts.append(
            f"{unopened} participant {links} never opened (not started): no study file was "
            "run on them and they are not counted in the sample."
        )
    return " ".join(parts)


def _column(participants: pd.DataFrame, name: str) -> pd.Series:
    if name not in participants.columns:
        return pd.Series([""] * len(participants), index=participants.index, dtype="object")
    return participants[name].astype(object).fillna("").astype(str)


def study_files(participants: pd.DataFrame) -> tuple[StudyFile, ...]:
    """The (study, digest) pairs of these participants, largest first.

    Participants without a digest in an export that has the column (trials outside the
    study flow) join their study's file when it has exactly one."""
    if participants.empty:
        return ()
    pairs = pd.DataFrame(
        {"study": _column(participants, "study"), "digest": _column(participants, "study_digest")}
    )
    counts = pairs.value_counts(sort=False).reset_index(name="n")
    files = {(str(row.study), str(row.digest)): int(row.n) for row in counts.itertuples()}
    outside: dict[tuple[str, str], int] = {}
    if "study_digest" in participants.columns:
        for (study, digest), n in list(files.items()):
            filed = [key for key in files if key[0] == study and key[1]]
            if not digest and len(filed) == 1:
                del files[(study, digest)]
                files[filed[0]] += n
                outside[filed[0]] = n
    ordered = sorted(files.items(), key=lambda item: (-item[1], item[0][0], item[0][1]))
    return tuple(
        StudyFile(study, digest, n, outside.get((study, digest), 0))
        for (study, digest), n in ordered
    )


def in_study(participants: pd.DataFrame, study: str) -> set[str]:
    """Codes of the participants of `study`."""
    chosen = _column(participants, "study") == study
    return set(participants.loc[chosen, "participant"].astype(str))


def refuse_pooling(files: tuple[StudyFile, ...]) -> None:
    """StudyPoolingError when participants ran more than one study file."""
    if len(files) <= 1:
        return
    named = "; ".join(file.label() for file in files)
    raise StudyPoolingError(
        f"the participants ran {len(files)} different study files ({named}). Their trials, "
        "timings and designs may differ, so they are not analysed together by default: pass "
        "--study NAME to analyse one, or --pool-studies to analyse them together."
    )


#: The export's status of a participant who reached the debrief.
COMPLETED = "completed"


def not_completed(participants: pd.DataFrame) -> set[str]:
    """Codes of the participants who did not complete (aborted, timed out, declined, in
    progress): their partial trials and answers enter the analysis unless
    ``--completers-only``, and the report says how many there are."""
    if participants.empty:
        return set()
    status = _column(participants, "status")
    return set(participants.loc[status != COMPLETED, "participant"].astype(str))
