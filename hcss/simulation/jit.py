"""Where the compiled kernels are cached, so each process compiles them at most once.

Numba's `cache=True` checks only the source file of the function it caches,
not the files of the functions it calls: after an edit to `messaging.py`, the
fused step in `step.py` would load its stale compiled copy. So the cache lives
in a directory named after a digest of every source file of this package (and
numba's version): any edit starts a fresh cache, an unchanged install reuses
it. The base directory is $HCSS_NUMBA_CACHE_DIR, else $NUMBA_CACHE_DIR, else
the user's cache directory (~/.cache/hcss/numba), else the temporary
directory: it works for an editable checkout, an installed (read-only)
package and CI alike. Imported by the package before any kernel is defined.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numba


def cache_dir() -> Path:
    sources = sorted(Path(__file__).parent.glob("*.py"))
    digest = hashlib.sha256(numba.__version__.encode())
    for source in sources:
        digest.update(source.name.encode())
        digest.update(source.read_bytes())
    base = (
        os.environ.get("HCSS_NUMBA_CACHE_DIR")
        or os.environ.get("NUMBA_CACHE_DIR")
        or os.path.join(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache", "hcss", "numba")
    )
    for root in (Path(base), Path(tempfile.gettempdir()) / f"hcss-numba-{os.getuid()}"):
        path = root / digest.hexdigest()[:20]
        try:
            path.mkdir(parents=True, exist_ok=True)
            probe = path / f".probe-{os.getpid()}"
            probe.write_bytes(b"")
            probe.unlink()
            return path
        except OSError:
            continue
    return Path(tempfile.mkdtemp(prefix="hcss-numba-"))


numba.config.CACHE_DIR = str(cache_dir())
