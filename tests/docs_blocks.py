"""Run the code blocks of a markdown file (README.md, docs/*.md), as a reader would.

Conventions (the docs follow them; :mod:`tests.test_docs` enforces them):

- A ````python`` block is executed; the blocks of one file run in order in one namespace
  (one session, like a REPL walkthrough), in a fresh process.
- A ````text`` block right after a python block is that block's printed output. It must
  match what the block prints; ``...`` in it matches any text (doctest's ELLIPSIS).
- A ````console`` block holds ``$ command`` lines, each followed by its expected output
  (``...`` as above). ``aiocram`` runs this checkout's command line; commands run in a
  temporary directory.
- Any other fenced block must be preceded by ``<!-- not run: REASON -->`` (e.g. the
  install commands, which CI runs verbatim), or the check fails: nothing in the docs may
  silently not run.

``python tests/docs_blocks.py FILE OUT`` runs FILE's python session and writes to OUT a
JSON list of ``{"index", "output", "error"}``; with ``--regen`` the test rewrites the ``text`` and
``console`` outputs from what really ran (then read the diff).
"""

from __future__ import annotations

import contextlib
import doctest
import io
import json
import re
import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

FENCE = re.compile(r"^```([A-Za-z0-9_-]*)[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)
NOT_RUN = re.compile(r"<!--\s*not run:\s*(.+?)\s*-->\s*$", re.S)


@dataclass
class Block:
    index: int  # position among the file's fenced blocks
    lang: str
    code: str
    start: int  # character offsets of the body in the file
    end: int
    line: int  # 1-based line of the opening fence
    not_run: str | None  # the reason given in a preceding <!-- not run: ... --> comment


def blocks(text: str) -> list[Block]:
    out = []
    for i, m in enumerate(FENCE.finditer(text)):
        before = text[: m.start()].rstrip()
        reason = NOT_RUN.search(before[-300:])
        out.append(
            Block(
                i,
                m.group(1).lower(),
                m.group(2),
                m.start(2),
                m.end(2),
                text.count("\n", 0, m.start()) + 1,
                reason.group(1) if reason else None,
            )
        )
    return out


def matches(expected: str, got: str) -> bool:
    """``got`` matches ``expected`` where each ``...`` stands for any text; trailing
    spaces of lines do not count (editors strip them)."""
    checker = doctest.OutputChecker()
    return checker.check_output(strip_lines(expected), strip_lines(got), doctest.ELLIPSIS)


def strip_lines(text: str) -> str:
    return "".join(line.rstrip() + "\n" for line in text.splitlines())


def run_python_session(path: Path) -> list[dict[str, object]]:
    """Execute the python blocks of ``path`` in order in one namespace."""
    namespace: dict[str, object] = {"__name__": "__docs__"}
    results = []
    for block in blocks(path.read_text()):
        if block.lang != "python":
            continue
        buffer = io.StringIO()
        error = None
        with contextlib.redirect_stdout(buffer):
            try:
                exec(compile(block.code, f"{path.name}:{block.line}", "exec"), namespace)
            except BaseException:  # reported to the test, which fails with it
                error = traceback.format_exc()
        results.append({"index": block.index, "output": buffer.getvalue(), "error": error})
        if error is not None:
            break
    return results


if __name__ == "__main__":
    Path(sys.argv[2]).write_text(json.dumps(run_python_session(Path(sys.argv[1]))))
