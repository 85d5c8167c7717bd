"""Task-tree snapshots: snapshot() of live-like tasks, TaskNode helpers, JSON round trip."""

from __future__ import annotations

import dataclasses
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cpl._failures import Evaporated, PlanFailure
from cpl._status import Status
from cpl._tree import (
    REPR_LIMIT,
    TREE_SCHEMA,
    FailureInfo,
    TaskNode,
    failure_info,
    jsonable,
    short_repr,
    snapshot,
)
from tests.cpl.fake_tasks import FakeTask

# --------------------------------------------------------------------------- fake tasks


class Designator:
    def __repr__(self) -> str:
        return "<a location (on (an object (type table))) " + "x" * 100 + ">"


class NavigationPoseUnreachable(PlanFailure):
    cram_name = "navigation-pose-unreachable"


def sample_tree() -> FakeTask:
    root = FakeTask("demo", kind="top-level", state=Status.RUNNING, end_time=None)
    trans = root.add(
        FakeTask("transporting", state=Status.RUNNING, end_time=None, arguments={"obj": "cup"})
    )
    trans.add(FakeTask("fetching", state=Status.SUCCEEDED, result=("cup", 1)))
    trans.add(
        FakeTask(
            "fetching",
            state=Status.FAILED,
            failure=NavigationPoseUnreachable("no pose", pose=(1.0, 2.0)),
            annotations={"designator": Designator(), "tries": 2, "pose": (1, 2)},
        )
    )
    p = trans.add(FakeTask("p", kind="par", state=Status.RUNNING, end_time=None))
    p.add(
        FakeTask(
            "a",
            kind="branch",
            state=Status.EVAPORATED,
            evaporation=Evaporated("sibling failed", by=("demo", "transporting", "p")),
        )
    )
    p.add(
        FakeTask(
            "b",
            kind="branch",
            state=Status.SUSPENDED,
            end_time=None,
            waiting_on="sleeping until t=3.2",
        )
    )
    p.add(FakeTask("c", kind="branch", state=Status.CREATED, start_time=None, end_time=None))
    return root


# --------------------------------------------------------------------------- snapshot


def test_snapshot_copies_fields_and_structure() -> None:
    snap = snapshot(sample_tree())
    assert snap.path == ("demo",)
    assert [n.name for n in snap.walk()] == [
        "demo",
        "transporting",
        "fetching",
        "fetching",
        "p",
        "a",
        "b",
        "c",
    ]
    second = snap.by_path(("demo", "transporting", "fetching#2"))
    assert second.failed and not second.succeeded
    assert second.failure == FailureInfo(
        type=f"{__name__}.NavigationPoseUnreachable",
        cram_name="navigation-pose-unreachable",
        message="no pose",
        details={"pose": "(1.0, 2.0)"},
    )
    assert second.annotations["tries"] == 2
    assert second.annotations["pose"] == [1, 2]
    designator = second.annotations["designator"]
    assert isinstance(designator, str) and len(designator) == REPR_LIMIT
    assert designator.startswith("<a location") and designator.endswith("...")
    first = snap.by_path("demo/transporting/fetching")
    assert first.result == "('cup', 1)"
    assert first.duration == 1.0
    assert snap.by_path("transporting").arguments == {"obj": "'cup'"}
    a = snap.find("a")
    assert a is not None and a.evaporated
    assert a.evaporated_by == ("demo", "transporting", "p")
    assert a.evaporation_reason == "sibling failed"
    b = snap.find("b")
    assert b is not None and b.waiting_on == "sleeping until t=3.2" and b.duration is None


def test_snapshot_is_frozen_and_detached() -> None:
    live = sample_tree()
    snap = snapshot(live)
    live.children[0].children.clear()
    live.children[0].state = Status.FAILED
    assert len(snap) == 8
    assert snap.children[0].status is Status.RUNNING
    with pytest.raises(dataclasses.FrozenInstanceError):
        snap.name = "other"  # type: ignore[misc]


def test_waiting_on_and_result_only_where_meaningful() -> None:
    t = FakeTask("x", state=Status.FAILED, waiting_on="stale", result=3)
    node = snapshot(t)
    assert node.waiting_on is None and node.result is None


def test_helpers() -> None:
    snap = snapshot(sample_tree())
    assert snap.find(lambda n: n.kind == "par") is snap.by_path(("demo", "transporting", "p"))
    assert snap.find("nothing") is None
    assert [n.path[-1] for n in snap.find_all("fetching")] == ["fetching", "fetching#2"]
    assert snap.child("transporting").name == "transporting"
    with pytest.raises(KeyError, match="no child 'nope'"):
        snap.child("nope")
    with pytest.raises(KeyError, match="no task at"):
        snap.by_path("demo/transporting/missing")
    assert snap.by_path(()) is snap
    assert "status=RUNNING" in repr(snap)
    assert hash(snap) == hash(snapshot(sample_tree()))


def test_collapsing_snapshot_counts_instead_of_copying() -> None:
    root = FakeTask("root", state=Status.RUNNING, end_time=None)
    for i in range(5):
        done = root.add(FakeTask(f"done{i}"))
        done.add(FakeTask("inner"))
    root.add(FakeTask("bad", state=Status.FAILED, failure=PlanFailure("x"))).add(
        FakeTask("ok-under-bad")
    )
    root.add(FakeTask("now", state=Status.RUNNING, end_time=None))
    snap = snapshot(root, collapse_finished=True)
    assert [c.name for c in snap.children] == ["bad", "now"]
    assert snap.collapsed == 10
    assert snap.child("bad").collapsed == 1 and snap.child("bad").children == ()


def test_capped_snapshot_counts_the_rest() -> None:
    root = FakeTask("root")
    for i in range(10):
        root.add(FakeTask(f"c{i}")).add(FakeTask("leaf"))
    snap = snapshot(root, max_nodes=4)
    assert len(snap) == 4
    assert sum(n.truncated for n in snap.walk()) == 21 - 4
    with pytest.raises(ValueError):
        snapshot(root, max_nodes=0)


def test_snapshot_falls_back_to_path_without_path_entry() -> None:
    root = FakeTask("r")
    child = root.add(FakeTask("k"))
    child.path_entry = None  # FakeTask.path then uses the name
    assert snapshot(root).children[0].path == ("r", "k")


def test_wide_tree_of_100k_tasks() -> None:
    root = FakeTask("root", kind="par-loop")
    for i in range(1000):
        group = root.add(FakeTask(f"g{i}", kind="branch"))
        for j in range(99):
            group.add(FakeTask(f"t{j}", arguments={"j": j}))
    snap = snapshot(root)
    assert len(snap) == 100_000 + 1
    assert snap.children[-1].children[-1].path == ("root", "g999", "t98")
    assert TaskNode.from_dict(snap.to_dict()) == snap
    small = snapshot(root, collapse_finished=True)
    assert small.children == () and small.collapsed == 100_000


def test_deep_chain() -> None:
    depth = 2000
    root = node = FakeTask("n0")
    for i in range(1, depth):
        node = node.add(FakeTask(f"n{i}"))
    snap = snapshot(root)
    assert len(snap) == depth
    deepest = list(snap.walk())[-1]
    assert len(deepest.path) == depth
    data = json.loads(json.dumps(snap.to_dict()))
    back = TaskNode.from_dict(data)
    assert back == snap
    assert back != snapshot(root, max_nodes=depth - 1)


# --------------------------------------------------------------------------- values


def test_short_repr_and_jsonable() -> None:
    class Broken:
        def __repr__(self) -> str:
            raise RuntimeError("no")

    assert short_repr(Broken()).startswith("<Broken object (repr failed")
    assert short_repr("a\nb") == "'a\\nb'"
    assert len(short_repr("x" * 500)) == REPR_LIMIT
    assert jsonable({"a": (1, 2.5, None)}) == {"a": [1, 2.5, None]}
    assert jsonable(float("nan")) == "nan"
    assert jsonable({1: 2}) == "{1: 2}"
    assert jsonable(Status.FAILED) == "Status.FAILED"


def test_failure_info_of_plain_errors() -> None:
    info = failure_info(ValueError("bad\nvalue"))
    assert info == FailureInfo("ValueError", "ValueError", "bad value", {})
    assert str(info) == "ValueError: bad value"


# --------------------------------------------------------------------------- JSON

_text = st.text(max_size=8)
_json = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats(allow_nan=False, allow_infinity=False)
    | _text,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(_text, inner, max_size=3),
    max_leaves=6,
)
_times = st.none() | st.floats(min_value=0, max_value=1e6, allow_nan=False)
_failures = st.none() | st.builds(
    FailureInfo,
    type=_text,
    cram_name=_text,
    message=_text,
    details=st.dictionaries(_text, _text, max_size=2),
)
_leaf = st.builds(
    TaskNode,
    name=_text,
    path=st.lists(_text, max_size=3).map(tuple),
    kind=st.sampled_from(["top-level", "plan", "par", "branch", "tag"]),
    status=st.sampled_from(list(Status)),
    start_time=_times,
    end_time=_times,
    arguments=st.dictionaries(_text, _text, max_size=2),
    result=st.none() | _text,
    failure=_failures,
    evaporated_by=st.none() | st.lists(_text, max_size=3).map(tuple),
    evaporation_reason=st.none() | _text,
    annotations=st.dictionaries(_text, _json, max_size=2),
    waiting_on=st.none() | _text,
    collapsed=st.integers(0, 5),
    truncated=st.integers(0, 5),
)
_trees = st.recursive(
    _leaf,
    lambda kids: st.builds(
        lambda base, children: dataclasses.replace(base, children=tuple(children)),
        _leaf,
        st.lists(kids, max_size=3),
    ),
    max_leaves=12,
)


@settings(max_examples=150, deadline=None)
@given(_trees)
def test_to_dict_from_dict_round_trip(node: TaskNode) -> None:
    data = node.to_dict()
    assert data["schema"] == TREE_SCHEMA
    assert TaskNode.from_dict(data) == node
    assert TaskNode.from_dict(json.loads(json.dumps(data))) == node


def test_from_dict_rejects_other_schemas() -> None:
    data = snapshot(sample_tree()).to_dict()
    with pytest.raises(ValueError, match=r"'aiocram\.task-tree/2'.*'aiocram\.task-tree/1'"):
        TaskNode.from_dict({**data, "schema": "aiocram.task-tree/2"})
    with pytest.raises(ValueError, match="schema None"):
        TaskNode.from_dict({"nodes": data["nodes"]})
    bad = json.loads(json.dumps(data))
    bad["nodes"][1]["parent"] = 5
    with pytest.raises(ValueError, match="invalid parent index"):
        TaskNode.from_dict(bad)
    bad = json.loads(json.dumps(data))
    bad["nodes"][2]["status"] = "exploded"
    with pytest.raises(ValueError, match="malformed task record"):
        TaskNode.from_dict(bad)


def test_rich_print_uses_display(capsys: pytest.CaptureFixture[str]) -> None:
    import rich

    rich.print(snapshot(sample_tree()))
    out = capsys.readouterr().out
    assert "transporting" in out and "navigation-pose-unreachable: no pose" in out
