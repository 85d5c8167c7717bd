"""A second Ctrl-C aborts the demo at once, and the forked picture worker goes with it:
nothing keeps writing into the output directory (and onto the shell prompt) after the
command ended (issue 27, item 5)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")

_SCRIPT = textwrap.dedent(
    """
    import os, signal, sys, time
    from pathlib import Path
    from aiocram.demo import _outputs
    from aiocram._interrupt import Interrupts
    from aiocram._outputs import Outputs

    out = Path(sys.argv[1])
    child_pid = out.parent / "child.pid"

    class Costmaps:
        uses = [1, 2]  # two costmaps: the second half is drawn by a forked child

        def figures(self, engine, staging, part):
            if part == (1, 2):  # the child: a slow picture
                written = child_pid.with_suffix(".tmp")  # whole or absent: renamed
                written.write_text(str(os.getpid()))
                written.rename(child_pid)
                time.sleep(30)
                (staging / "late.png").write_text("drawn after the command ended")
                return
            deadline = time.monotonic() + 30  # the parent: Ctrl-C twice meanwhile
            while not child_pid.exists() and time.monotonic() < deadline:
                time.sleep(0.01)
            # two presses, the second once the first was handled (signals do not queue:
            # two sent at once may arrive as one)
            os.kill(os.getpid(), signal.SIGINT)
            while interrupts.count < 1 and time.monotonic() < deadline:
                time.sleep(0.01)
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(30)

    outputs = Outputs(out)
    with Interrupts() as interrupts:
        interrupts.on_abort = lambda: outputs.commit()
        _outputs.write_pictures(outputs, None, None, Costmaps(), ["engine"], interrupts)
    sys.exit("not aborted")
    """
)


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_a_second_ctrl_c_kills_the_picture_worker(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", _SCRIPT, str(out)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=120,
        check=False,
    )
    assert proc.returncode == 130, proc.stderr
    assert "aborted" in proc.stderr
    child = int((tmp_path / "child.pid").read_text())
    try:
        assert not _alive(child), "the picture worker outlived the aborted command"
    finally:
        if _alive(child):
            os.kill(child, 9)
    assert not list(out.glob(".partial-*"))  # the abort committed and removed the staging
