"""Every code block of README.md and docs/*.md runs, and the output shown is the output
produced (see :mod:`docs_blocks` for the conventions). Regenerate the shown outputs after
a deliberate change with ``AIOCRAM_REGEN_DOCS=1 python -m pytest tests/test_docs.py`` and
read the diff."""

from __future__ import annotations

import itertools
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from .docs_blocks import Block, blocks, matches, strip_lines

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
REGEN = os.environ.get("AIOCRAM_REGEN_DOCS") == "1"
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "80", "NO_COLOR": "1"}
RUNS = {"python", "text", "console"}


def _ids(paths: list[Path]) -> list[str]:
    return [str(p.relative_to(ROOT)) for p in paths]


def _replace(path: Path, edits: list[tuple[Block, str]]) -> None:
    text = path.read_text()
    for block, body in sorted(edits, key=lambda e: -e[0].start):
        text = text[: block.start] + body + text[block.end :]
    path.write_text(text)


@pytest.mark.parametrize("path", DOCS, ids=_ids(DOCS))
def test_every_block_runs_or_says_why_not(path: Path) -> None:
    unexplained = [
        f"{path.name}:{b.line} ```{b.lang or '(no language)'}"
        for b in blocks(path.read_text())
        if b.lang not in RUNS and b.not_run is None
    ]
    assert not unexplained, (
        "blocks that would not run: make them python/text/console blocks, or precede them "
        f"with <!-- not run: REASON -->: {unexplained}"
    )
    found = blocks(path.read_text())
    for b, nxt in itertools.pairwise(found):
        if nxt.lang == "text":
            assert b.lang == "python", f"{path.name}:{nxt.line}: a text block follows python"


@pytest.mark.parametrize("path", DOCS, ids=_ids(DOCS))
def test_python_blocks_run_and_print_what_is_shown(path: Path, tmp_path: Path) -> None:
    found = blocks(path.read_text())
    if not any(b.lang == "python" for b in found):
        pytest.skip("no python blocks")
    result_file = tmp_path / "results.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "tests" / "docs_blocks.py"), str(path), str(result_file)],
        cwd=tmp_path,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = {r["index"]: r for r in json.loads(result_file.read_text())}
    edits = []
    for b, nxt in zip(found, [*found[1:], None]):
        if b.lang != "python":
            continue
        result = results.get(b.index)
        assert result is not None, f"{path.name}:{b.line}: not run (an earlier block failed)"
        assert result["error"] is None, f"{path.name}:{b.line}:\n{result['error']}"
        if nxt is not None and nxt.lang == "text":
            if REGEN:
                edits.append((nxt, strip_lines(result["output"])))
            else:
                assert matches(nxt.code, result["output"]), (
                    f"{path.name}:{nxt.line}: shown output differs from the real one:\n"
                    f"--- shown\n{nxt.code}--- real\n{result['output']}"
                )
        else:
            assert not result["output"].strip() or REGEN, (
                f"{path.name}:{b.line} prints output that the docs do not show: "
                f"add a ```text block after it:\n{result['output']}"
            )
    if REGEN and edits:
        _replace(path, edits)


#: What varies from run to run in a command's output, replaced by ``...`` when the shown
#: outputs are regenerated: wall-clock times.
VOLATILE = (
    (re.compile(r"in \d+\.\d s wall time"), "in ... s wall time"),
    # the wall seconds each transport spent imagining
    (re.compile(r"imagined (\d+) runs in \d+\.\d+ s"), r"imagined \1 runs in ... s"),
    # the demo table's last column (wall seconds spent imagining)
    (re.compile(r"^(│(?:[^│\n]*│){5})[^│\n]*│$", re.M), r"\1...│"),
)


def _steady(text: str) -> str:
    for pattern, replacement in VOLATILE:
        text = pattern.sub(replacement, text)
    return text


def _console(block: Block) -> list[tuple[str, str]]:
    """(command, expected output) pairs of a console block."""
    pairs: list[tuple[str, list[str]]] = []
    for line in block.code.splitlines(keepends=True):
        if line.startswith("$ "):
            pairs.append((line[2:].strip(), []))
        else:
            assert pairs, f"console block at line {block.line} must start with '$ command'"
            pairs[-1][1].append(line)
    return [(cmd, "".join(out)) for cmd, out in pairs]


@pytest.mark.parametrize("path", DOCS, ids=_ids(DOCS))
def test_console_blocks_print_what_is_shown(path: Path, tmp_path: Path) -> None:
    found = [b for b in blocks(path.read_text()) if b.lang == "console"]
    if not found:
        pytest.skip("no console blocks")
    edits = []
    for block in found:
        new_body = []
        for command, expected in _console(block):
            argv = shlex.split(command)
            if argv[0] == "aiocram":
                argv = [sys.executable, "-m", "aiocram.cli", *argv[1:]]
            elif argv[0] == "python":
                argv = [sys.executable, *argv[1:]]
            proc = subprocess.run(
                argv,
                cwd=tmp_path if argv[1:2] != ["examples"] else ROOT,
                env=ENV,
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
            )
            got = proc.stdout
            assert proc.returncode in (0, 1), f"{command}: exit {proc.returncode}\n{proc.stderr}"
            if REGEN:
                new_body.append(f"$ {command}\n{strip_lines(_steady(got))}")
            else:
                assert matches(expected, got), (
                    f"{path.name}:{block.line}: `{command}` printed something else:\n"
                    f"--- shown\n{expected}--- real\n{got}"
                )
        edits.append((block, "".join(new_body)))
    if REGEN:
        _replace(path, edits)


def test_the_check_can_fail(tmp_path: Path) -> None:
    """A block whose shown output is wrong, and one that raises, are both caught."""
    doc = tmp_path / "doc.md"
    doc.write_text("```python\nprint(1 + 1)\n```\n\n```text\n3\n```\n\n```python\n1 / 0\n```\n")
    out = tmp_path / "out.json"
    subprocess.run(
        [sys.executable, str(ROOT / "tests" / "docs_blocks.py"), str(doc), str(out)],
        env=ENV,
        check=True,
        timeout=120,
    )
    first, second = json.loads(out.read_text())
    assert first["output"] == "2\n" and not matches("3\n", first["output"])
    assert matches("...\n", first["output"])
    assert "ZeroDivisionError" in second["error"]
    bare = blocks("```\nno language\n```\n")
    assert bare[0].lang == "" and bare[0].not_run is None  # would fail the first test
    explained = blocks("<!-- not run: needs a robot -->\n```bash\nreboot\n```\n")
    assert explained[0].not_run == "needs a robot"
