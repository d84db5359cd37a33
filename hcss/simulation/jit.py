"""Where the compiled kernels are cached, so each process compiles them at most once;
and `internal`, the decorator of kernels that only other kernels call.

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
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn, TypeVar, cast

import numba
from numba.core.registry import CPUDispatcher


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


#: A kernel: the function `internal` compiles.
F = TypeVar("F", bound=Callable[..., Any])

numba.config.CACHE_DIR = str(cache_dir())  # type: ignore[attr-defined]  # set from the environment at run time


class _CompiledCallersOnly(CPUDispatcher):
    """A dispatcher compiled without the wrappers that let Python call it."""

    def __call__(self, *args: Any, **kwargs: Any) -> NoReturn:
        # Without its Python wrapper a call from Python would crash the process.
        raise TypeError(
            f"{self.py_func.__qualname__} is called only from compiled code; "
            "call its module's Python entry point instead"
        )


def internal(func: F) -> F:
    """`njit(cache=True)` for a kernel that only other compiled functions call.

    numba compiles every function with two entry wrappers, one for calls from
    Python and one for C. For a kernel that takes the world's 27 arrays
    (`world.Arrays`) the Python one, which unboxes each array, is about as
    much code as the kernel; without them the first call with an empty cache
    takes about 2 s less. Calling such a kernel from Python raises TypeError,
    so a module gives its Python callers a small `@njit` function that calls it.
    """
    dispatcher = _CompiledCallersOnly(
        func,
        locals={},
        targetoptions={"nopython": True, "no_cpython_wrapper": True, "no_cfunc_wrapper": True},
    )
    dispatcher.enable_caching()
    return cast(F, dispatcher)  # typed as the function it compiles, for its compiled callers
