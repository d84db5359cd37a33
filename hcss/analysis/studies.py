"""Which study files the analysed participants ran, and refusing to pool them by accident.

One server runs several study files: the protocol, and a demo with 2-minute
trials for walk-throughs whose participants come through the same kind of
link and are not flagged. Their data must never land in one analysis
unnoticed. The export's participants table names each participant's study
and the digest of its file; the analysis keeps one study when asked
(`--study`), refuses to pool different files unless asked (`--pool-studies`),
and the report names every study it includes.
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

    def label(self) -> str:
        digest = self.digest[:12] if self.digest else "digest not exported"
        return f"{self.name} ({digest}): {self.participants} participant(s)"


def _column(participants: pd.DataFrame, name: str) -> pd.Series:
    if name not in participants.columns:
        return pd.Series([""] * len(participants), index=participants.index, dtype="object")
    return participants[name].astype(object).fillna("").astype(str)


def study_files(participants: pd.DataFrame) -> tuple[StudyFile, ...]:
    """The (study, digest) pairs of these participants, largest first."""
    if participants.empty:
        return ()
    pairs = pd.DataFrame(
        {"study": _column(participants, "study"), "digest": _column(participants, "study_digest")}
    )
    counts = pairs.value_counts(sort=False).reset_index(name="n")
    counts = counts.sort_values(["n", "study", "digest"], ascending=[False, True, True])
    return tuple(
        StudyFile(str(row.study), str(row.digest), int(row.n)) for row in counts.itertuples()
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
