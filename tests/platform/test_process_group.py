"""`hcss serve --processes N` and `hcss deploy nginx`: refused on SQLite, a configuration nginx accepts."""

from __future__ import annotations

import subprocess

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.platform.serving.localserver import LocalNginx


@pytest.mark.parametrize("options", [["--processes", "2"], ["--cluster"]])
def test_several_processes_on_sqlite_are_refused_with_the_reason(options, tmp_path, monkeypatch):
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path / 'one.sqlite3'}")
    result = CliRunner().invoke(main, ["serve", *options])
    assert result.exit_code == 2
    assert "need PostgreSQL" in result.output and "SQLite serves one process" in result.output


def test_deploy_nginx_routes_every_participant_path_by_token(tmp_path) -> None:
    result = CliRunner().invoke(
        main, ["deploy", "nginx", "--server", "10.0.0.2:5000", "--server", "10.0.0.3:5000"]
    )
    assert result.exit_code == 0, result.output
    text = result.output
    assert "~^/(?:p|live|api/live)/(?<token>[^/]+) $token;" in text
    # nginx's plain hash, which the processes reproduce (hcss.platform.live.placement),
    # and the group they must be told, in the same order.
    assert "hash $hcss_token;" in text and "consistent" not in text
    assert "HCSS_GROUP=10.0.0.2:5000,10.0.0.3:5000" in text
    # A named location per member, for a request forwarded to a trial's holder.
    assert (
        "location @hcss_10.0.0.2:5000 {" in text and "location @hcss_10.0.0.3:5000_stream {" in text
    )
    # Each client capped and slow ones timed out (issue 41 item 8).
    assert "limit_conn hcss_clients 64;" in text and "client_header_timeout 10s;" in text
    assert "client_body_timeout 10s;" in text and "send_timeout 15s;" in text
    assert "server 10.0.0.2:5000" in text and "server 10.0.0.3:5000" in text
    assert "proxy_buffering off;" in text and "3600s" not in text  # a hung process times out
    assert "proxy_read_timeout 3s;" in text and "proxy_read_timeout 15s;" in text
    assert "proxy_next_upstream error timeout http_502 http_503 non_idempotent;" in text


def test_the_standalone_configuration_is_valid_nginx(tmp_path) -> None:
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY} (scripts/ensure-nginx installs it)")
    config = tmp_path / "nginx.conf"
    result = CliRunner().invoke(
        main,
        ["deploy", "nginx", "--processes", "3", "--standalone", str(tmp_path), "-o", str(config)],
    )
    assert result.exit_code == 0, result.output
    check = subprocess.run(
        [LocalNginx.BINARY, "-t", "-p", str(tmp_path), "-c", str(config)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert check.returncode == 0, check.stderr
