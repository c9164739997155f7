"""The Python module on a map on a PostgreSQL server (ctest's pg_server fixture runs this file
through pytest; its name keeps it out of the plain `pytest tests/python` run)."""
import os
import pathlib
import subprocess

import pytest

import placedb
from test_placedb import scene


def server_uri():
    uri_file = os.environ.get("PLACEDB_TEST_PG_URI_FILE", "")
    line = pathlib.Path(uri_file).read_text().strip() if uri_file else ""
    if not line.startswith("postgresql://"):
        pytest.skip(f"no PostgreSQL server: {line or 'run through ctest'}")
    return line


def fresh_database(name):
    uri = server_uri()
    for sql in (f"DROP DATABASE IF EXISTS {name} WITH (FORCE)", f"CREATE DATABASE {name}"):
        subprocess.run(["psql", uri, "-XAtqc", sql], check=True, capture_output=True)
    return uri.replace("/placedb?", f"/{name}?")


def tour(path):
    with placedb.Map(path) as m:
        m.begin_session("tour")
        return [(r.accepted, r.score, [f.source_index for f in r.matched_frames])
                for r in (m.process(scene(seed)) for seed in list(range(24)) + list(range(8)))]


def test_a_server_map_decides_as_a_file(tmp_path):
    uri = fresh_database("py_server_map")
    on_file = tour(str(tmp_path / "tour.placedb"))
    assert tour(uri) == on_file
    assert any(accepted for accepted, _, _ in on_file)
    assert placedb.loop_closures(uri) == placedb.loop_closures(str(tmp_path / "tour.placedb"))
    with placedb.Map(uri, read_only=True) as m:
        assert m.query(scene(3), top=1).matches


def test_a_wrong_password_raises_auth_refused_without_the_password():
    uri = server_uri()
    host = uri[uri.index("host="):].split("&")[0]
    with pytest.raises(placedb.AuthRefused) as raised:
        placedb.Map(f"postgresql://nobody_here:not-this-one@/placedb?{host}", read_only=True)
    assert raised.value.exit_code == 12
    assert "not-this-one" not in str(raised.value)
    with pytest.raises(placedb.ServerUnreachable):
        placedb.Map("postgresql:///placedb?host=/nonexistent-folder", read_only=True)
