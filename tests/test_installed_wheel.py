"""The built wheel works outside the checkout: migrations, studies and the data
dictionary are package data, so `pip install hcss` gives a lab a working platform.

The wheel is built from the checkout's sources and installed, without its
dependencies, into a new virtual environment in a temporary directory. The
dependencies (numpy, Flask, ...) are those of the test's own environment,
reached through a `.pth` line placed after the new environment's own
site-packages; that line adds a directory without running its `.pth` files, so
the checkout's editable install stays inactive, and the test checks that every
command imports hcss from the new environment. Every command runs from a
directory outside the checkout.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from hcss.platform.serving.localserver import LocalServer

CHECKOUT = Path(__file__).resolve().parents[1]


def _run(command: list[str], cwd: Path, env: dict[str, str], timeout: float = 300) -> str:
    done = subprocess.run(
        command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False
    )
    assert done.returncode == 0, f"{' '.join(command)}\n{done.stdout}\n{done.stderr}"
    return done.stdout


def _build_wheel(work: Path) -> Path:
    """The wheel of a copy of the sources (a build leaves nothing in the checkout)."""
    source = work / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(CHECKOUT / "hcss", source / "hcss", ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(CHECKOUT / name, source / name)
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation"]
    _run([*command, "-q", "-w", str(work / "dist"), str(source)], work, dict(os.environ))
    (wheel,) = (work / "dist").glob("hcss-*.whl")
    return wheel


def _environment_with(wheel: Path, venv: Path) -> Path:
    """A new virtual environment holding the wheel; its interpreter."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    install = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q"]
    _run([*install, "--no-deps", "--no-index", str(wheel)], venv, dict(os.environ))
    own = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    (own / "zz_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return python


@pytest.mark.slow
def test_the_installed_wheel_runs_the_study_end_to_end(tmp_path: Path) -> None:
    python = _environment_with(_build_wheel(tmp_path), tmp_path / "venv")
    hcss = str(python.parent / "hcss")
    away = tmp_path / "elsewhere"  # the working directory of every command
    away.mkdir()
    database_url = f"sqlite:///{tmp_path / 'study.sqlite3'}"
    env = {
        key: value
        for key, value in os.environ.items()
        if key not in ("PYTHONPATH", "DATABASE_URL", "HCSS_STUDIES", "VIRTUAL_ENV")
    }
    env |= {"DATABASE_URL": database_url, "HCSS_INSTANCE_PATH": str(tmp_path / "instance")}

    where = _run([str(python), "-c", "import hcss; print(hcss.__file__)"], away, env)
    assert where.startswith(str(tmp_path / "venv")), where

    assert "at revision head" in _run([hcss, "db", "upgrade"], away, env)
    server_env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": "60"}
    server = LocalServer(
        database_url, tmp_path / "instance", extra_env=server_env, python=str(python)
    )
    # A fresh install has no compiled-kernel cache: `hcss serve` compiles before it listens.
    server.start(timeout_s=300)
    try:
        # Creates the bot participant in the database, then walks it through every
        # page of the demo study over HTTP, as a browser would.
        walked = _run(
            [hcss, "bots", "--n", "1", "--study", "demo", "--base-url", server.url],
            away,
            env,
            timeout=600,
        )
        log = server.log_path.read_text()
    finally:
        server.stop()
    assert "1 completed, 0 failed" in walked, walked
    assert "Traceback" not in log, log

    _run([hcss, "export", str(tmp_path / "export")], away, env)
    export = tmp_path / "export"
    assert (export / "data-dictionary.md").read_text().startswith("# ")
    assert (export / "participants.csv").read_text().count("\n") == 2  # header and the bot

    report = tmp_path / "report"
    _run(
        [hcss, "analyze", str(export), "--include-pilot", "--quiet", "--out", str(report)],
        away,
        env,
    )
    assert (report / "report.html").is_file()
    assert any((report / "tables").glob("*.csv"))
