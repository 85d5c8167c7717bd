"""The experience store on a real PostgreSQL server (issue 29): ``.ci/run`` installs and
starts Debian's ``postgresql`` and exports ``AIOCRAM_TEST_POSTGRES_URL``. Without it these
tests skip locally, and fail in CI (``CI=true``), so the path cannot silently go untested.
The database is the tests' own: its tables are dropped first."""

from __future__ import annotations

import json
import os
from typing import Any

import pytest
from sqlalchemy import create_engine, func, select, text

from aiocram.cli import main
from aiocram.experience import SCHEMA_VERSION, Store, StoreVersionError
from aiocram.experience._schema import metadata, nodes, runs

pytestmark = pytest.mark.timeout(900)

URL_VARIABLE = "AIOCRAM_TEST_POSTGRES_URL"


@pytest.fixture
def url() -> Any:
    value = os.environ.get(URL_VARIABLE)
    if not value:
        if os.environ.get("CI") == "true":
            pytest.fail(f"{URL_VARIABLE} is not set in CI: .ci/run must start PostgreSQL")
        pytest.skip(f"{URL_VARIABLE} not set (.ci/run sets it)")
    engine = create_engine(value)
    with engine.begin() as conn:  # a clean database for each test
        metadata.drop_all(conn)
    engine.dispose()
    return value


def test_the_dask_workers_write_a_campaign_into_postgresql(url, tmp_path):
    out = tmp_path / "c"
    args = ["campaign", "--seeds", "1", "--faults", "0.1", "--objects", "cup", "--workers", "2"]
    assert main([*args, "--backend", "dask", "--store", url, "--out", str(out)]) in (0, 1)
    summary = json.loads((out / "campaign.json").read_text())["summary"]["experience"]
    assert summary["runs_recorded"] == 2 and summary["runs_not_recorded"] == 0
    assert summary["write_s"] == 0.0  # the parent wrote nothing: the workers did
    assert not (out / "experience.sqlite").exists()
    with Store(url) as store:
        assert store.run_count() == 2
        with store.engine.connect() as conn:
            imagined = conn.execute(
                select(func.count()).where(nodes.c.imagined.is_(True))
            ).scalar_one()
            (campaign,) = conn.execute(select(runs.c.campaign).distinct()).scalars().all()
        assert imagined > 0 and campaign == summary["campaign"]
        kinds = store.failures_by("kind")
        by_robot = store.failures_by("robot")
        assert sum(n for _, n in kinds) == sum(n for _, n in by_robot)
        assert store.parameters("cup")
        cmp = store.compare(campaign, campaign)
        assert cmp.before.runs == 2


def test_a_newer_schema_on_the_server_is_refused(url):
    with Store(url, create=True) as store, store.engine.begin() as conn:
        conn.execute(
            text("INSERT INTO experience_schema VALUES (:v, 'from the future', 'x')"),
            {"v": SCHEMA_VERSION + 1},
        )
    with pytest.raises(StoreVersionError, match="newer than this aiocram's"):
        Store(url, create=True)
