"""The experience store (issue 29), on a store built by a small real campaign: every run
recorded with its real and imagined task tree and chosen parameters, the questions
answered from it (API and CLI), and the bad stores refused before anything runs."""

from __future__ import annotations

import json
import socket
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import func, select, text

from aiocram.cli import main
from aiocram.experience import (
    SCHEMA_VERSION,
    Store,
    StoreCorruptError,
    StoreError,
    StoreLockedError,
    StoreMissingError,
    StoreUnreachableError,
    StoreVersionError,
)
from aiocram.experience._schema import nodes, parameters, runs

pytestmark = pytest.mark.timeout(900)

OBJECTS = ["cup", "bowl"]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Two real campaigns into one store: ``--seeds 2 --faults 0,0.1`` (both modes), then
    one more run (``--faults 0.2 --no-projection``, ``--overwrite``: the store stays)."""
    out = tmp_path_factory.mktemp("campaign") / "c"
    common = ["--objects", *OBJECTS, "--workers", "2", "--out", str(out)]
    first = main(["campaign", "--seeds", "2", "--faults", "0,0.1", *common])
    assert first in (0, 1)
    a = json.loads((out / "campaign.json").read_text())
    records_a = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    second = main(
        ["campaign", "--seeds", "1", "--faults", "0.2", "--no-projection", "--overwrite", *common]
    )
    assert second in (0, 1)
    b = json.loads((out / "campaign.json").read_text())
    return {
        "out": out,
        "store": out / "experience.sqlite",
        "a": a["summary"]["experience"],
        "b": b["summary"]["experience"],
        "records_a": records_a,
        "runs_b": b["runs"],
    }


def test_every_run_is_recorded_with_its_real_and_imagined_tree(campaign):
    a, b = campaign["a"], campaign["b"]
    assert a["runs_recorded"] == 8 and a["runs_not_recorded"] == 0
    assert b["runs_recorded"] == 1 and a["campaign"] != b["campaign"]
    # the rows went to the store, not into runs.jsonl
    assert all("experience" not in r for r in campaign["records_a"])
    with Store(campaign["store"]) as store:
        assert store.run_count() == 9
        with store.engine.connect() as conn:
            per_run = conn.execute(
                select(
                    runs.c.id,
                    runs.c.projection,
                    runs.c.campaign,
                    runs.c.seed,
                    runs.c.delivered,
                    func.sum(nodes.c.imagined.cast(int_type())),
                    func.count(),
                )
                .join(nodes, nodes.c.run_id == runs.c.id)
                .group_by(runs.c.id)
            ).all()
    assert len(per_run) == 9
    for _, projection, _, _, _, imagined, total in per_run:
        assert total > 50  # the whole tree, not a summary
        assert (imagined > 0) is bool(projection)  # imagined runs only with projection
    # the delivered counts are the true world's, as in runs.jsonl
    delivered = {
        (r["seed"], r["fault_rate"], r["projection"]): sum(
            1 for o in r["objects"].values() if o["delivered"]
        )
        for r in campaign["records_a"]
    }
    with Store(campaign["store"]) as store, store.engine.connect() as conn:
        stored = {
            (s, f, p): d
            for s, f, p, d in conn.execute(
                select(runs.c.seed, runs.c.fault_rate, runs.c.projection, runs.c.delivered).where(
                    runs.c.campaign == a["campaign"]
                )
            )
        }
    assert stored == delivered


def int_type() -> Any:
    from sqlalchemy import Integer

    return Integer


def test_failures_are_counted_once_where_they_arose(campaign):
    with Store(campaign["store"]) as store:
        by_kind = dict(store.failures_by("kind"))
        totals = {by: sum(n for _, n in store.failures_by(by)) for by in ("kind", "object", "step")}
        with store.engine.connect() as conn:
            failed = conn.execute(
                select(func.count()).where(
                    nodes.c.failure_class.is_not(None), nodes.c.imagined.is_(False)
                )
            ).scalar_one()
        imagined = store.failures_by("kind", imagined=True)
    assert len(set(totals.values())) == 1  # one failure, one count, whatever the grouping
    # a failure passes through several tasks: counted where it arose only
    assert 0 < sum(by_kind.values()) < failed
    assert imagined  # the imagined runs failed too, and are asked separately
    with pytest.raises(StoreError, match="one of kind, object, step, robot"):
        Store(campaign["store"]).failures_by("colour")


def test_retries_per_recovery_match_the_runs(campaign):
    expected: dict[str, int] = {}
    for record in [*campaign["records_a"], *campaign["runs_b"]]:
        for o in record["objects"].values():
            for kind, n in o["retries"].items():
                expected[kind] = expected.get(kind, 0) + n
    with Store(campaign["store"]) as store:
        got = {kind: spent for kind, spent, _, _ in store.retries()}
    assert got == {k: v for k, v in expected.items() if v}


def test_parameters_of_each_pick_and_place(campaign):
    with Store(campaign["store"]) as store:
        picks = store.parameters("cup")
        places = store.parameters("cup", action="placing")
        surfaces = store.surfaces("cup")
        on_surface = store.parameters("cup", surface=surfaces[0])
        with store.engine.connect() as conn:
            real_picks = conn.execute(
                select(func.count()).where(
                    parameters.c.object == "cup",
                    parameters.c.action == "picking-up",
                    parameters.c.imagined.is_(False),
                )
            ).scalar_one()
            bases = conn.execute(
                select(func.count()).where(parameters.c.base_x.is_not(None))
            ).scalar_one()
    assert sum(p.tried for p in picks) == real_picks > 0
    assert all(p.arm in ("left", "right") and p.grasp for p in picks)
    assert any(p.succeeded for p in picks) and any(p.succeeded for p in places)
    best = picks[0]
    assert best.mean_rel_x is not None and 0.2 < best.mean_rel_x < 1.2  # the object ahead
    assert bases > 0
    assert surfaces and sum(p.tried for p in on_surface) <= real_picks


def test_compare_two_campaigns(campaign):
    with Store(campaign["store"]) as store:
        cmp = store.compare(campaign["a"]["campaign"], campaign["b"]["campaign"])
        with pytest.raises(StoreError, match="names no campaign or commit"):
            store.compare("nosuchcampaign", campaign["a"]["campaign"])
        with pytest.raises(StoreError, match="matches 2 campaigns"):  # same date and hour
            store.compare(campaign["a"]["campaign"][:9], campaign["a"]["campaign"])
    assert (cmp.before.runs, cmp.after.runs) == (8, 1)
    assert cmp.before.objects == 16 and cmp.after.objects == 2
    delivered = sum(
        1 for r in campaign["records_a"] for o in r["objects"].values() if o["delivered"]
    )
    assert cmp.before.delivered == delivered


@pytest.mark.parametrize(
    ("question", "shows"),
    [
        (["failures"], "failures by kind"),
        (["failures", "--by", "robot"], "pr2"),
        (["failures", "--by", "step", "--imagined"], "imagined runs"),
        (["retries"], "retries spent per recovery"),
        (["parameters", "--object", "bowl"], "picking-up bowl"),
        (["parameters", "--object", "cup", "--action", "placing"], "placing cup"),
    ],
)
def test_the_cli_answers(campaign, capsys, question, shows):
    assert main(["experience", *question, "--store", str(campaign["store"])]) == 0
    assert shows in capsys.readouterr().out


def test_the_cli_compares_and_plots(campaign, capsys, tmp_path):
    store = str(campaign["store"])
    a, b = campaign["a"]["campaign"], campaign["b"]["campaign"]
    assert main(["experience", "compare", a, b, "--store", store]) == 0
    assert "delivered" in capsys.readouterr().out
    png = tmp_path / "f.png"
    assert main(["experience", "plot", "--store", store, "--png", str(png)]) == 0
    from PIL import Image

    with Image.open(png) as image:
        assert image.size[0] > 400 and image.size[1] > 300
    assert main(["experience", "parameters", "--object", "spoon", "--store", store]) == 2
    assert "no picking-up of spoon" in capsys.readouterr().err


# ----------------------------------------------------------------------- bad stores
def _newer(path: Path) -> None:
    with Store(path, create=True) as store, store.engine.begin() as conn:
        conn.execute(
            text("INSERT INTO experience_schema VALUES (:v, 'from the future', 'x')"),
            {"v": SCHEMA_VERSION + 1},
        )


def test_a_new_store_is_migrated_once(tmp_path):
    path = tmp_path / "e.sqlite"
    for _ in range(2):
        Store(path, create=True).close()
    with sqlite3.connect(path) as conn:
        rows = conn.execute("SELECT version FROM experience_schema").fetchall()
    assert rows == [(SCHEMA_VERSION,)]


def test_a_store_from_a_newer_aiocram_is_refused(tmp_path):
    path = tmp_path / "e.sqlite"
    _newer(path)
    before = path.read_bytes()
    with pytest.raises(StoreVersionError, match="newer than this aiocram's"):
        Store(path, create=True)
    with pytest.raises(StoreVersionError):
        Store(path)
    assert path.read_bytes() == before


def test_a_corrupt_file_is_refused_and_left_alone(tmp_path):
    path = tmp_path / "e.sqlite"
    path.write_bytes(b"this is not a database" * 100)
    with pytest.raises(StoreCorruptError, match="not a readable SQLite database"):
        Store(path, create=True)
    assert path.read_bytes() == b"this is not a database" * 100
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE photos (id INTEGER)")
    with pytest.raises(StoreCorruptError, match="not an aiocram experience store"):
        Store(other, create=True)


def test_a_locked_file_is_refused(tmp_path):
    path = tmp_path / "e.sqlite"
    Store(path, create=True).close()
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")  # another writer holds the lock
    try:
        with pytest.raises(StoreLockedError, match="locked by another process"):
            Store(path, create=True)
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    Store(path, create=True).close()  # free again: fine


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_server_that_does_not_answer_is_refused():
    url = f"postgresql+psycopg://aiocram@127.0.0.1:{_closed_port()}/experience"
    with pytest.raises(StoreUnreachableError, match="did not answer"):
        Store(url, create=True)


def test_questions_never_create_a_store(tmp_path, capsys):
    path = tmp_path / "none.sqlite"
    with pytest.raises(StoreMissingError, match="run a demo or a campaign first"):
        Store(path)
    assert main(["experience", "failures", "--store", str(path)]) == 2
    assert "no experience store at" in capsys.readouterr().err
    assert not path.exists()


@pytest.mark.parametrize(
    ("url", "message"),
    [("mysql://u@h/db", "SQLite .* or PostgreSQL"), ("sqlite://", "give a file")],
)
def test_unsupported_urls(url, message):
    with pytest.raises(StoreError, match=message):
        Store(url, create=True)


def test_the_campaign_refuses_a_bad_store_before_any_run(tmp_path, capsys):
    out = tmp_path / "c"
    out.mkdir()
    (out / "experience.sqlite").write_bytes(b"garbage" * 50)
    args = ["campaign", "--seeds", "1", "--faults", "0", "--no-projection", "--objects", "cup"]
    assert main([*args, "--out", str(out)]) == 2
    assert "not a readable SQLite database" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["experience.sqlite"]
    newer = tmp_path / "newer.sqlite"
    _newer(newer)
    assert main([*args, "--out", str(tmp_path / "d"), "--store", str(newer)]) == 2
    assert "newer than this aiocram's" in capsys.readouterr().err
    assert not (tmp_path / "d" / "runs.jsonl").exists()


def test_the_demo_refuses_a_bad_store_before_it_runs(tmp_path, capsys):
    store = tmp_path / "e.sqlite"
    _newer(store)
    out = tmp_path / "demo"
    args = ["demo", "--objects", "cup", "--no-live", "--out", str(out), "--store", str(store)]
    assert main(args) == 2
    assert "newer than this aiocram's" in capsys.readouterr().err
    assert not out.exists()


def test_the_demo_records_its_run(tmp_path, capsys):
    out = tmp_path / "demo"
    args = ["demo", "--objects", "cup", "--runs", "2", "--no-live", "--out", str(out)]
    assert main(args) in (0, 1)
    assert "experience.sqlite" in capsys.readouterr().out
    with Store(out / "experience.sqlite") as store, store.engine.connect() as conn:
        ((source, robot, projection, seed),) = conn.execute(
            select(runs.c.source, runs.c.robot, runs.c.projection, runs.c.seed)
        ).all()
        imagined = conn.execute(select(func.count()).where(nodes.c.imagined.is_(True))).scalar_one()
        picks = conn.execute(select(func.count()).select_from(parameters)).scalar_one()
    assert (source, robot, projection, seed) == ("demo", "pr2", True, 1)
    assert imagined and picks
    assert main([*args, "--no-store", "--out", str(tmp_path / "d2")]) in (0, 1)
    assert not (tmp_path / "d2" / "experience.sqlite").exists()


def test_a_crashed_run_is_recorded_and_a_run_not_written_is_counted(tmp_path, monkeypatch):
    """The campaign's side: a run the harness lost is a run row with its error; a run
    whose rows cannot be written (the file stays locked) is counted, not dropped."""
    import aiocram.experience._engine as engine
    from aiocram.campaign import CampaignStore

    monkeypatch.setattr(engine, "LOCK_TIMEOUT_S", 0.2)
    sink = CampaignStore(tmp_path / "e.sqlite")
    crashed = {
        "robot": "pr2",
        "seed": 7,
        "fault_rate": 0.1,
        "projection": True,
        "error": "WorkerDied: the worker process running this job was killed by SIGKILL",
        "objects": {},
        "planned": ["cup", "bowl"],
        "invariants": {},
        "wall_time_s": 1.0,
    }
    sink.take(dict(crashed))
    assert (sink.recorded, sink.errors) == (1, [])
    holder = sqlite3.connect(tmp_path / "e.sqlite", isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")
    try:
        sink.take({**crashed, "seed": 8})
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    assert sink.recorded == 1 and len(sink.errors) == 1 and "locked" in sink.errors[0]
    assert sink.summary()["runs_not_recorded"] == 1
    sink.close()
    with Store(tmp_path / "e.sqlite") as store, store.engine.connect() as conn:
        rows = conn.execute(select(runs.c.seed, runs.c.error, runs.c.objects)).all()
    assert [(s, o) for s, _, o in rows] == [(7, 2)] and "WorkerDied" in rows[0][1]


def test_on_dask_with_sqlite_the_parent_writes(tmp_path):
    pytest.importorskip("dask.distributed")
    out = tmp_path / "d"
    args = ["campaign", "--seeds", "1", "--faults", "0", "--no-projection", "--objects", "cup"]
    assert main([*args, "--backend", "dask", "--workers", "1", "--out", str(out)]) in (0, 1)
    summary = json.loads((out / "campaign.json").read_text())["summary"]["experience"]
    assert summary["runs_recorded"] == 1 and summary["write_s"] > 0  # written here
    with Store(out / "experience.sqlite") as store:
        assert store.run_count() == 1 and store.parameters("cup")
