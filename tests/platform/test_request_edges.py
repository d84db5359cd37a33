"""Malformed requests a fuzzer or an attacker sends get a 4xx, and pages are never cached."""

from __future__ import annotations

import csv

import pytest

from hcss.platform.export.writer import write_export
from tests.support.recruitment import join


@pytest.mark.parametrize("host", ["a" * 64 + ".example", "a..b"])
def test_a_host_header_that_is_not_a_hostname_is_a_400_on_every_route(
    app, make_trial, host: str
) -> None:
    trial = make_trial()
    for method, path in (
        ("GET", "/"),
        ("GET", f"/p/{trial.token}"),
        ("GET", f"/live/{trial.token}"),
        ("GET", "/console/login"),
        ("POST", "/console/login"),
        ("GET", f"{trial.api}/state"),
        ("GET", "/no/such/page"),
    ):
        response = app.test_client().open(path, method=method, headers={"Host": host})
        assert response.status_code == 400, (host, method, path, response.status_code)
        assert "Traceback" not in response.get_data(as_text=True)


def _multipart(field_name: str) -> tuple[bytes, str]:
    boundary = "hcss-boundary"
    body = (
        f"--{boundary}\r\n"
        f'Content-Disposition: form-data; name="{field_name}"\r\n\r\n'
        "value\r\n"
        f"--{boundary}--\r\n"
    ).encode()
    return body, f"multipart/form-data; boundary={boundary}"


def test_a_multipart_field_named_backslash_is_refused_on_every_post_route(app, make_trial) -> None:
    trial = make_trial()
    body, content_type = _multipart("\\")
    for path in ("/console/login", f"/p/{trial.token}", f"{trial.api}/requests", "/console/logout"):
        response = app.test_client().post(path, data=body, content_type=content_type)
        assert 400 <= response.status_code < 500, (path, response.status_code)


def test_console_and_participant_pages_are_not_stored_by_caches(app, make_trial, console) -> None:
    trial = make_trial()
    for response in (
        console.get("/console/"),
        console.get("/console/progress.json"),
        app.test_client().get("/console/login"),
        trial.client.get(f"/p/{trial.token}", follow_redirects=True),
        trial.client.get(f"/live/{trial.token}"),
        trial.client.get(f"{trial.api}/state"),
    ):
        assert "no-store" in response.headers.get("Cache-Control", ""), response.request.path


#: pandas' default missing-value strings (`pandas.read_csv` na_values), which an id may be.
PANDAS_MISSING = {"NA", "N/A", "NaN", "nan", "-NaN", "-nan", "NULL", "null", "None", "n/a"}


def test_recruitment_ids_are_exported_so_spreadsheets_run_no_formula_and_keep_every_id(
    app, tmp_path
) -> None:
    ids = ["+1-2", "-SUM", "@cmd", "NaN", "null", "None", "5f8a1b2c3d4e"]
    client = app.test_client()
    for recruitment_id in ids:
        assert join(client, PROLIFIC_PID=recruitment_id).status_code == 302
    with app.extensions["hcss_db"].session_scope() as session:
        write_export(session, tmp_path / "export")
    with (tmp_path / "export" / "recruitment.csv").open(encoding="utf-8") as handle:
        written = [row["recruitment_id"] for row in csv.DictReader(handle)]
    assert len(written) == len(ids)
    for value in written:
        assert value[0] not in "=+-@\t\r", value
        assert value not in PANDAS_MISSING, value
    # One leading apostrophe is the only change: stripping it gives the id back.
    assert [value[1:] if value.startswith("'") else value for value in written] == ids
