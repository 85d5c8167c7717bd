"""examples/07 replays the seed's REPL walkthrough with the seed's own numbers."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_example_07_replays_the_seed_with_its_numbers() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "07_seed_walkthrough.py")],
        capture_output=True,
        text=True,
        timeout=300,  # a hung run fails instead of hanging the suite
        env=env,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout
    # the seed's numbers, as written
    going = "(perform <an action (type going) (target <a location (pose <Pose map (-0.500 0.000"
    assert going in out
    assert "pose=<Pose base_footprint (1.000 0.000 1.300)" in out  # the cup seen 1 m ahead
    assert "held by l_wrist_roll_link at <Pose map (0.500 0.300 1.067)" in out
    assert "the cup followed the hand: <Pose map (0.000 0.300 1.067)" in out
    assert "held: nothing" in out
    assert "ObjectOutcome(type='bowl', name='bowl-1', success=True" in out


def test_example_07_runs_through_with_the_panda() -> None:
    """The seed's robot-independent steps with the mobile Panda: the seed's hand pose is
    beyond its arm, and its mast camera does not see the cup at (0.5, 0.3, 1.0) from the
    PR2's view point (its parked hand is in the way): both said, not raised; it then
    turns towards the cup to detect it, turns back, picks it up, carries it and puts it
    down."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "07_seed_walkthrough.py"), "3", "panda"],
        capture_output=True,
        text=True,
        timeout=300,  # a hung run fails instead of hanging the suite
        env=env,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "pose=<Pose base_footprint (1.000 0.000 1.300)" in out  # the cup seen 1 m ahead
    assert "beyond this robot's left arm" in out
    assert "not seen from there" in out and "turning towards the cup instead" in out
    assert "held by panda_hand at <Pose map (0.500 0.300" in out
    assert "the cup followed the hand: <Pose map (0.000 0.300" in out
    assert "held: nothing" in out
    assert "ObjectOutcome(type='bowl', name='bowl-1', success=True" in out
