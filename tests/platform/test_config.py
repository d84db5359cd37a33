"""Settings from the environment: the database URL and the instance folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from hcss.platform import config


@pytest.mark.parametrize(
    ("given", "used"),
    [
        ("postgres://u:pw@db.example:5433/hcss", "postgresql+psycopg://u:pw@db.example:5433/hcss"),
        ("postgresql://u@db.example/hcss", "postgresql+psycopg://u@db.example/hcss"),
        ("postgresql+psycopg://u@db.example/hcss", "postgresql+psycopg://u@db.example/hcss"),
        # A password with URL syntax in it stays one password, escaped once.
        (
            "postgres://u:p%40ss%2Fw@db.example/hcss",
            "postgresql+psycopg://u:p%40ss%2Fw@db.example/hcss",
        ),
        ("sqlite:////srv/hcss.sqlite3", "sqlite:////srv/hcss.sqlite3"),
        # Query options are kept (a TLS mode, a schema search path).
        (
            "postgres://u@db.example/hcss?sslmode=require",
            "postgresql+psycopg://u@db.example/hcss?sslmode=require",
        ),
    ],
)
def test_database_url_names_the_driver_sqlalchemy_needs(
    monkeypatch: pytest.MonkeyPatch, given: str, used: str
) -> None:
    monkeypatch.setenv("DATABASE_URL", given)
    assert config.database_url() == used


def test_a_database_url_that_is_not_one_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DATABASE_URL", "db.example:5432")
    with pytest.raises(ValueError, match="DATABASE_URL"):
        config.database_url()


def test_without_settings_the_database_is_in_the_instance_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.delenv("DATABASE_URL", raising=False)
    monkeypatch.setenv("HCSS_INSTANCE_PATH", str(tmp_path))
    assert config.database_url() == f"sqlite:///{tmp_path / 'hcss.sqlite3'}"


def test_a_checkout_keeps_its_instance_folder_in_the_checkout() -> None:
    assert config.default_instance_path() == Path(config.__file__).resolve().parents[2] / "instance"
