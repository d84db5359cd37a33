"""The console's download: the export directory as one zip, audited."""

from __future__ import annotations

import io
import tempfile
import zipfile
from pathlib import Path

from hcss.platform.db import Database
from hcss.platform.export.writer import write_export
from hcss.platform.models import AuditRecord


def export_archive(
    database: Database, experimenter: str, study: str | None = None
) -> tuple[io.BytesIO, str]:
    """(zip bytes, file name); the zip holds the files `hcss export [--study]` writes."""
    stamp = database.now().strftime("%Y%m%dT%H%M%SZ")
    name = f"hcss-export-{study}-{stamp}" if study else f"hcss-export-{stamp}"
    buffer = io.BytesIO()
    with tempfile.TemporaryDirectory() as scratch:
        outdir = Path(scratch) / name
        with database.session_scope() as session:
            counts = write_export(session, outdir, study=study)
            session.add(
                AuditRecord(
                    action="export",
                    experimenter=experimenter,
                    participant_code=None,
                    row_counts=counts,
                )
            )
        with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(outdir.rglob("*")):
                if path.is_file():
                    archive.write(path, f"{name}/{path.relative_to(outdir).as_posix()}")
    buffer.seek(0)
    return buffer, f"{name}.zip"
