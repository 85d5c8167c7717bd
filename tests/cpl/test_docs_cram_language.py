"""Every code block of docs/cram_language.md runs, and prints the output shown under it.

Each block runs in its own Python process with a time-out (a hung example fails the test;
it cannot freeze the suite)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "cram_language.md"
BLOCK = re.compile(r"```(\w+)\n(.*?)```", re.S)


def blocks() -> list[tuple[str, str | None]]:
    found = BLOCK.findall(DOC.read_text())
    out: list[tuple[str, str | None]] = []
    for i, (lang, code) in enumerate(found):
        if lang != "python":
            continue
        shown = found[i + 1][1] if i + 1 < len(found) and found[i + 1][0] == "text" else None
        out.append((code, shown))
    return out


def test_the_doc_has_examples() -> None:
    assert len(blocks()) >= 3
    assert all(shown is not None for _, shown in blocks()), "every example shows its output"


@pytest.mark.parametrize("index", range(len(blocks())))
def test_doc_example_runs_and_prints_what_is_shown(index: int) -> None:
    code, shown = blocks()[index]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    proc = subprocess.run(
        [sys.executable, "-W", "error", "-c", code],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == shown
