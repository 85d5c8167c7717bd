"""``aiocram show`` on damaged event logs: one line saying it cannot read the file and
why, exit status 2, no traceback and no half-drawn tree, whatever the damage."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from aiocram.cli import main
from cpl._eventlog import EVENT_SCHEMA
from tests.cpl.test_eventlog import fake_run, write_log

Events = list[dict[str, Any]]


def _good(tmp_path: Path) -> tuple[list[str], Events]:
    path = tmp_path / "good.jsonl"
    write_log(path, fake_run())
    lines = path.read_text().splitlines()
    return lines, [json.loads(line) for line in lines]


def _ev(event: str, path: list[str], parent: list[str] | None = None, **kw: Any) -> dict[str, Any]:
    name = path[-1]
    return {"schema": EVENT_SCHEMA, "event": event, "path": path, "parent": parent,
            "name": name, "kind": "plan", "status": "running", **kw}  # fmt: skip


def _changed(events: Events, index: int, **fields: Any) -> Events:
    out = [dict(e) for e in events]
    for key, value in fields.items():
        if value is ...:
            out[index].pop(key, None)
        else:
            out[index][key] = value
    return out


def _deep_cycle() -> Events:
    """a under r, b under a, then a moved under b: a cycle of parent links."""
    return [
        _ev("run-started", ["r"]),
        _ev("task-started", ["r", "a"], ["r"]),
        _ev("task-started", ["r", "a", "b"], ["r", "a"]),
        _ev("task-started", ["r", "a"], ["r", "a", "b"], moved_from=["r", "a"]),
    ]


def _root_under_child() -> Events:
    return [
        _ev("run-started", ["r"]),
        _ev("task-started", ["r", "a"], ["r"]),
        _ev("task-started", ["r"], ["r", "a"], moved_from=["r"]),
    ]


# each: (lines, events of the good log) -> the damaged file's bytes
DAMAGE: dict[str, Callable[[list[str], Events], bytes]] = {
    "empty file": lambda lines, evs: b"",
    "blank lines only": lambda lines, evs: b"\n  \n\n",
    "png image": lambda lines, evs: b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)),
    "binary with NUL": lambda lines, evs: b'{"a": 1}\x00\x01\x02\n',
    "latin-1 text": lambda lines, evs: (
        "\n".join(lines).replace("demo", "d\u00e9mo").encode("latin-1")
    ),
    "line cut in the middle": lambda lines, evs: "\n".join(
        [lines[0], lines[1][:40], *lines[2:]]
    ).encode(),
    "json arrays": lambda lines, evs: b"[1, 2]\n[3]\n",
    "json scalars": lambda lines, evs: b'42\n"x"\nnull\n',
    "path a number": lambda lines, evs: _jsonl(_changed(evs, 1, path=5)),
    "path a string": lambda lines, evs: _jsonl(_changed(evs, 1, path="demo/par")),
    "path missing": lambda lines, evs: _jsonl(_changed(evs, 1, path=...)),
    "path of lists": lambda lines, evs: _jsonl(_changed(evs, 1, path=[["demo"], {"a": 1}])),
    "path empty": lambda lines, evs: _jsonl(_changed(evs, 0, path=[])),
    "parent a number": lambda lines, evs: _jsonl(_changed(evs, 1, parent=7)),
    "parent of numbers": lambda lines, evs: _jsonl(_changed(evs, 1, parent=[1, 2])),
    "status unknown": lambda lines, evs: _jsonl(_changed(evs, 2, status="bogus")),
    "status a number": lambda lines, evs: _jsonl(_changed(evs, 2, status=3)),
    "run without status": lambda lines, evs: _jsonl(_changed(evs, 0, status=...)),
    "start time a string": lambda lines, evs: _jsonl(_changed(evs, 2, start_time="noon")),
    "end time a list": lambda lines, evs: _jsonl(_changed(evs, 2, end_time=[1, 2])),
    "end time 1e400": lambda lines, evs: (
        "\n".join(lines).replace('"end_time":9.0', '"end_time":1e400').encode()
    ),
    "end time NaN": lambda lines, evs: (
        "\n".join(lines).replace('"end_time":9.0', '"end_time":NaN').encode()
    ),
    "end time 4000 digits": lambda lines, evs: (
        "\n".join(lines).replace('"end_time":9.0', '"end_time":' + "9" * 4000).encode()
    ),
    "end time 5000 digits": lambda lines, evs: (
        "\n".join(lines).replace('"end_time":9.0', '"end_time":' + "9" * 5000).encode()
    ),
    "name an object": lambda lines, evs: _jsonl(_changed(evs, 2, name={"a": [1]})),
    "kind a number": lambda lines, evs: _jsonl(_changed(evs, 2, kind=5)),
    "arguments a list": lambda lines, evs: _jsonl(_changed(evs, 2, arguments=[1, 2])),
    "annotations a number": lambda lines, evs: _jsonl(_changed(evs, 2, annotations=5)),
    "failure a number": lambda lines, evs: _jsonl(_changed(evs, 3, failure=5)),
    "failure misshapen": lambda lines, evs: _jsonl(_changed(evs, 3, failure={"type": 5})),
    "evaporated_by a number": lambda lines, evs: _jsonl(_changed(evs, 4, evaporated_by=5)),
    "moved_from a number": lambda lines, evs: _jsonl(_changed(evs, 5, moved_from=5)),
    "event type missing": lambda lines, evs: _jsonl(_changed(evs, 1, event=...)),
    "schema missing": lambda lines, evs: _jsonl(_changed(evs, 1, schema=...)),
    "only run-finished": lambda lines, evs: _jsonl(evs[-1:]),
    "task its own parent": lambda lines, evs: _jsonl(
        [_ev("run-started", ["r"]), _ev("task-started", ["r", "a"], ["r", "a"])]
    ),
    "cycle of parent links": lambda lines, evs: _jsonl(_deep_cycle()),
    "top level moved under its child": lambda lines, evs: _jsonl(_root_under_child()),
    "second run damaged": lambda lines, evs: _jsonl([*evs, evs[0], _changed(evs, 1, path=5)[1]]),
    "braces only": lambda lines, evs: b"{" * 100_000 + b"\n",
    "json nested 100000 deep": lambda lines, evs: (
        '{"schema": "aiocram.events/1", "event": "run-started", "path": ["r"], "name": "r", '
        '"status": "running", "arguments": {"a": ' + "[" * 100_000 + "]" * 100_000 + "}}\n"
    ).encode(),
}


def _jsonl(events: Events) -> bytes:
    return "".join(json.dumps(e) + "\n" for e in events).encode()


def _show(path: Path, *extra: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(["show", str(path), *extra])  # any exception fails the test: a traceback
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("kind", sorted(DAMAGE))
@pytest.mark.parametrize("ascii_", [False, True])
def test_a_damaged_log_is_one_clean_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, ascii_: bool
) -> None:
    lines, events = _good(tmp_path)
    path = tmp_path / "damaged.jsonl"
    path.write_bytes(DAMAGE[kind](lines, events))
    code, out, err = _show(path, *(["--ascii"] if ascii_ else []), capsys=capsys)
    assert code == 2
    assert out == ""  # no half-drawn tree
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"aiocram show: error: cannot read {path}: ")
    assert len(err) < 300 + len(str(path)) + 60


def test_messages_say_what_is_wrong(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines, events = _good(tmp_path)
    expected = {
        "png image": "not a text file: byte 0 (0x89) is not UTF-8 text",
        "path a number": ":2: 'path' must be a non-empty list of task names, got 5",
        "end time NaN": ":1: 'end_time' must be null or a finite number, got nan",
        "cycle of parent links": "a cycle of parent links",
        "json nested 100000 deep": ":1: JSON nested too deeply to be an event",
    }
    for kind, message in expected.items():
        path = tmp_path / "damaged.jsonl"
        path.write_bytes(DAMAGE[kind](lines, events))
        assert message in _show(path, capsys=capsys)[2], kind


def test_a_folder_and_a_bad_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "logs"
    folder.mkdir()
    code, out, err = _show(folder, capsys=capsys)
    assert (code, out) == (2, "")
    problem = "it is a folder; give the event log file in it"
    assert err == f"aiocram show: error: cannot read {folder}: {problem}\n"
    write_log(tmp_path / "good.jsonl", fake_run())
    assert main(["show", str(tmp_path / "good.jsonl"), "--max-nodes", "abc"]) == 2
    err = capsys.readouterr().err
    assert "argument --max-nodes: must be a whole number >= 1, got 'abc'" in err
    assert "_positive" not in err


def test_deep_and_wide_logs_still_draw(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Damage checks must not refuse (or be slow on) big but sound logs."""
    events = [_ev("run-started", ["r"])]
    parent = ["r"]
    for i in range(3000):
        path = [*parent, f"t{i}"]
        events.append(_ev("task-started", path, parent))
        parent = path
    log = tmp_path / "deep.jsonl"
    log.write_bytes(_jsonl(events))
    code, out, err = _show(log, "--ascii", "--max-nodes", "5", capsys=capsys)
    assert (code, err) == (0, "")
    assert "t3" in out and "more" in out
