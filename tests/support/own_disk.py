"""A small file system of the test's own (tmpfs), which the test may fill or make read-only.

Real faults, not stubs: SQLite meets ENOSPC or EROFS from the kernel. Needs
the right to mount (the tests run as root here); skipped otherwise.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

CHUNK = 65536


@dataclass
class OwnDisk:
    path: Path

    @property
    def filler(self) -> Path:
        return self.path / "filler"

    def fill(self) -> None:
        """Take every free byte."""
        with self.filler.open("wb", buffering=0) as handle:
            try:
                while True:
                    handle.write(b"\0" * CHUNK)
            except OSError:
                pass
        assert shutil.disk_usage(self.path).free < CHUNK

    def free(self) -> None:
        self.filler.unlink()

    def _remount(self, mode: str) -> None:
        subprocess.run(["mount", "-o", f"remount,{mode}", str(self.path)], check=True)

    def read_only(self) -> None:
        self._remount("ro")

    def writable(self) -> None:
        self._remount("rw")


@contextmanager
def own_disk(tmp_path: Path, size: str = "32m") -> Iterator[OwnDisk]:
    mount_point = tmp_path / "disk"
    mount_point.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mount_point)],
        capture_output=True,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small disk: {mounted.stderr.decode().strip()}")
    try:
        yield OwnDisk(mount_point)
    finally:
        subprocess.run(["umount", "-l", str(mount_point)], check=False)
