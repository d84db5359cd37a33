"""Where the tables of one INPUT come from: a folder, the console's zip, a CSV or Parquet file.

The console's download is a zip holding one folder of CSV files; ``hcss
export`` writes the same folder; the simulation-only experiment writes a
decisions CSV. Each table may also be Parquet (same columns), which keeps a
large decisions table small. This module only finds and reads the raw
tables; :mod:`hcss.analysis.load` checks and combines them.
"""

from __future__ import annotations

import io
import zipfile
import zlib
from pathlib import Path, PurePosixPath

import pandas as pd

#: A zip member larger than this is refused (the export of a whole study is
#: a few MB; this stops a zip bomb before pandas inflates it).
MAX_MEMBER_BYTES = 512 * 1024 * 1024
#: The longest line a CSV table may hold. The export's longest rows (a free-text answer)
#: are well under 1 KiB; a file without line breaks would otherwise be parsed as one
#: ever-growing field (a 50 MB such file ran past 2 GB of memory).
MAX_LINE_BYTES = 64 * 1024
#: Bytes scanned at a time when checking line lengths.
_SCAN_BYTES = 1024 * 1024


class SourceError(ValueError):
    """An INPUT that is not a table, folder or zip the analysis can read."""


def _check_lines(source: io.BytesIO | Path, where: str, table: str) -> None:
    """Refuse a CSV with a line longer than :data:`MAX_LINE_BYTES` before pandas reads it.

    The scan reads fixed-size blocks, so its memory is bounded whatever the file holds;
    a file larger than a study export can be (:data:`MAX_MEMBER_BYTES`) is refused first.
    """
    if isinstance(source, Path) and source.stat().st_size > MAX_MEMBER_BYTES:
        raise SourceError(
            f"{where}: the {table} table is larger than a study export can be "
            f"({source.stat().st_size / 1e6:.0f} MB; at most {MAX_MEMBER_BYTES // 2**20} MiB)"
        )
    stream = source if isinstance(source, io.BytesIO) else source.open("rb")
    try:
        line, current = 1, 0
        while block := stream.read(_SCAN_BYTES):
            start = 0
            while (newline := block.find(b"\n", start)) >= 0:
                current += newline - start
                if current > MAX_LINE_BYTES:
                    break
                line, current, start = line + 1, 0, newline + 1
            else:
                current += len(block) - start
            if current > MAX_LINE_BYTES:
                raise SourceError(
                    f"{where}: line {line} of the {table} table is longer than "
                    f"{MAX_LINE_BYTES // 1024} KiB: not a table of the export "
                    "(a file without line breaks?)"
                )
    finally:
        if isinstance(source, io.BytesIO):
            source.seek(0)
        else:
            stream.close()


def _read(
    source: io.BytesIO | Path, suffix: str, text_columns: frozenset[str], where: str, table: str
) -> pd.DataFrame:
    """One table, with any reading error explained for the command line."""
    if suffix != ".parquet":
        _check_lines(source, where, table)
    try:
        if suffix == ".parquet":
            frame = pd.read_parquet(source)
            for name in text_columns.intersection(frame.columns):
                frame[name] = frame[name].astype("string")
            return frame
        return pd.read_csv(source, dtype={name: "string" for name in text_columns})
    except pd.errors.EmptyDataError as error:
        raise SourceError(f"{where}: the {table} table is empty (no header)") from error
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as error:
        raise SourceError(f"{where}: cannot read the {table} table: {error}") from error
    except (ValueError, ImportError) as error:  # pyarrow on a damaged Parquet file
        raise SourceError(f"{where}: cannot read the {table} table: {error}") from error


def _folder_tables(folder: Path) -> dict[str, Path]:
    """Table name -> file for every CSV or Parquet file directly in ``folder``."""
    found: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.is_file() and path.suffix in (".csv", ".parquet"):
            found.setdefault(path.stem, path)
    return found


def _zip_tables(archive: zipfile.ZipFile, where: Path) -> dict[str, zipfile.ZipInfo]:
    """Table name -> member for the CSV/Parquet members of the export's top folder.

    The console's zip holds one folder; its ``training/`` subfolder (practice
    trials) is not part of the analysis, exactly as in an export folder.
    """
    members = [
        info
        for info in archive.infolist()
        if not info.is_dir() and PurePosixPath(info.filename).suffix in (".csv", ".parquet")
    ]
    if not members:
        return {}
    top = min(len(PurePosixPath(info.filename).parts) for info in members)
    members = [info for info in members if len(PurePosixPath(info.filename).parts) == top]
    if len({PurePosixPath(info.filename).parent for info in members}) > 1:
        raise SourceError(f"{where}: the zip holds several exports; give them one by one")
    found: dict[str, zipfile.ZipInfo] = {}
    for info in sorted(members, key=lambda info: info.filename):
        if info.file_size > MAX_MEMBER_BYTES:
            raise SourceError(f"{where}: {info.filename} is larger than a study export can be")
        found.setdefault(PurePosixPath(info.filename).stem, info)
    return found


def read_tables(
    path: Path, wanted: tuple[str, ...], text_columns: frozenset[str]
) -> dict[str, tuple[str, pd.DataFrame]]:
    """Table name -> (where it was read, raw frame) for the ``wanted`` tables of one INPUT.

    A single CSV or Parquet file is the decisions table. A folder or zip
    gives every wanted table it holds; missing tables are simply absent.
    Reading errors become :class:`SourceError` with the file named.
    """
    try:
        if path.is_file() and zipfile.is_zipfile(path):
            with zipfile.ZipFile(path) as archive:
                members = _zip_tables(archive, path)
                tables = {}
                for name in wanted:
                    if name in members:
                        where = f"{path}:{members[name].filename}"
                        content = io.BytesIO(archive.read(members[name]))
                        suffix = PurePosixPath(members[name].filename).suffix
                        tables[name] = (where, _read(content, suffix, text_columns, where, name))
                return tables
        if path.is_file():
            if path.suffix not in (".csv", ".parquet"):
                raise SourceError(f"{path}: not a CSV, Parquet or zip file")
            frame = _read(path, path.suffix, text_columns, str(path), "decisions")
            return {"decisions": (str(path), frame)}
        if path.is_dir():
            files = _folder_tables(path)
            return {
                name: (
                    str(files[name]),
                    _read(files[name], files[name].suffix, text_columns, str(path), name),
                )
                for name in wanted
                if name in files
            }
    except (OSError, zipfile.BadZipFile, zlib.error, EOFError) as error:
        raise SourceError(f"{path}: cannot read it (damaged?): {error}") from error
    except NotImplementedError as error:  # zipfile: a compression method it lacks
        raise SourceError(f"{path}: cannot read it: {error}") from error
    except RuntimeError as error:  # zipfile: an encrypted member without a password
        raise SourceError(
            f"{path}: cannot read it: {error}; export it again unencrypted"
        ) from error
    raise SourceError(f"{path}: no such file or directory")
