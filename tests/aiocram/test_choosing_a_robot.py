"""Choosing a robot (issue 25, the application side): ``robots.by_name``/``names``,
``aiocram demo --robot``, ``aiocram campaign --robots``, the run's robot in its record and
in the experience store, and the truth checks and costmap footprint read from the robot's
description rather than from the PR2's constants.

Two tests need the projection to load the Panda's own body (issue 25, the projection's
part): they are skipped, saying so, until it does (:func:`_panda_body_loads`)."""

from __future__ import annotations

import math
import sqlite3
from types import SimpleNamespace

import pytest

import robots
import robots.panda
import robots.pr2
from aiocram.campaign import INVARIANTS, plan_campaign, summarise, summary_table
from aiocram.demo import DemoConfig, DemoConfigError, run_demo
from aiocram.experience import robot_name

PR2 = robots.by_name("pr2")
PANDA = robots.by_name("panda")


# ------------------------------------------------------------------ robots.by_name
def test_the_robots_package_names_its_robots_without_a_registry():
    assert robots.names() == ("panda", "pr2")  # mobile_base holds parts: no robot
    assert robots.by_name("pr2") is robots.pr2.DESCRIPTION
    assert robots.by_name("panda") is robots.panda.DESCRIPTION


@pytest.mark.parametrize("name", ["tiago", "mobile_base", "_urdf_tools", "pr2.x", ""])
def test_an_unknown_robot_is_a_typed_error_listing_the_known_ones(name):
    with pytest.raises(robots.UnknownRobot, match="describes panda, pr2") as info:
        robots.by_name(name)
    assert info.value.known == ("panda", "pr2")
    assert isinstance(info.value, LookupError)


# ------------------------------------------------------------------ demo --robot
def test_demo_config_names_the_robot_flag_and_the_known_robots(tmp_path):
    out = tmp_path / "never"
    with pytest.raises(DemoConfigError, match=r"--robot tiago: unknown robot; known: panda, pr2"):
        run_demo(DemoConfig(robot="tiago", out=out, live=False))
    assert not out.exists()  # refused before anything was written
    with pytest.raises(DemoConfigError, match="--robot takes a robot's name"):
        DemoConfig(robot=3).check()
    DemoConfig(robot="panda").check()
    DemoConfig(robot=PANDA).check()  # a description of one's own is taken as it is


def test_demo_command_refuses_an_unknown_robot_before_writing(tmp_path, capsys):
    from aiocram.cli import main

    out = tmp_path / "out"
    assert main(["demo", "--robot", "tiago", "--out", str(out), "--no-live"]) == 2
    err = capsys.readouterr().err
    assert "--robot tiago" in err and "panda, pr2" in err
    assert not out.exists()


def _robot_seen(seen):
    async def plan(world, config):
        from executive import current_environment

        env = current_environment()
        seen.update(true=world.robot, belief=env.world.robot, env=env.robot)
        return {}

    return plan


@pytest.mark.parametrize("name", ["pr2", "panda"])
def test_the_chosen_robot_reaches_both_worlds_the_report_and_the_store(tmp_path, name):
    """The plumbing: ``--robot NAME`` builds both worlds with that description, the
    plan's environment has it, the report and its JSON record name it, and the experience
    store records the run under it."""
    seen: dict[str, object] = {}
    store = tmp_path / "e.sqlite"
    config = DemoConfig(objects=("cup",), robot=name, runs=1, live=False, store=store)
    report = run_demo(config, plan=_robot_seen(seen))
    description = robots.by_name(name)
    assert seen == {"true": description, "belief": description, "env": description}
    assert report.robot == name
    assert report.to_json()["robot"] == name
    with sqlite3.connect(store) as db:
        assert db.execute("SELECT robot FROM runs").fetchall() == [(name,)]


def test_the_summary_says_which_robot_ran():
    from rich.console import Console

    from aiocram.demo import DemoReport, outcome_table

    report = DemoReport(DemoConfig(robot="panda"), {}, {}, {}, 0.0, 0.0)
    console = Console(width=80, record=True, color_system=None)
    console.print(outcome_table(report, 80))
    assert "table setting by panda, seed 1" in console.export_text()


def test_robot_name_is_the_runs_robot_never_a_constant():
    assert robot_name(PANDA) == "panda"
    assert robot_name(PR2) == "pr2"
    assert robot_name("xarm6") == "xarm6"
    with pytest.raises(TypeError, match="RobotDescription or its name"):
        robot_name(None)


# ------------------------------------------------------------------ campaign --robots
def test_campaign_crosses_robots_with_seeds_modes_and_rates():
    jobs = plan_campaign(seeds=2, faults=[0.0, 0.1], projection_modes=(True,), robots="pr2,panda")
    cells = [(j.seed, j.robot, j.fault_rate) for j in jobs]
    assert cells == [
        (1, "pr2", 0.0),
        (1, "pr2", 0.1),
        (1, "panda", 0.0),
        (1, "panda", 0.1),
        (2, "pr2", 0.0),
        (2, "pr2", 0.1),
        (2, "panda", 0.0),
        (2, "panda", 0.1),
    ]
    assert {j.robot for j in plan_campaign(seeds=1, faults=[0.0])} == {"pr2"}


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("pr2,tiago", "--robots: tiago: unknown robot; known: panda, pr2"),
        ("pr2,pr2", "--robots: pr2 given more than once"),
        ("pr2,", "give names separated by commas"),
        ("", "--robots needs at least one robot"),
    ],
)
def test_bad_robots_are_refused_before_any_job(given, message):
    with pytest.raises(ValueError, match=message):
        plan_campaign(seeds=1, faults=[0.0], robots=given)


def test_campaign_command_refuses_bad_robots_before_writing(tmp_path, capsys):
    from aiocram.campaign import main

    out = tmp_path / "c"
    assert main(["campaign", "--robots", "pr2,tiago", "--seeds", "1", "--out", str(out)]) == 2
    assert "--robots: tiago" in capsys.readouterr().err
    assert not out.exists()


def _record(robot, seed, delivered):
    objects = {
        f"o{i}": {"claimed": True, "delivered": i < delivered, "where": "island"} for i in range(5)
    }
    return {
        "robot": robot,
        "seed": seed,
        "fault_rate": 0.1,
        "projection": True,
        "objects": objects,
        "distance_driven": 10.0,
        "real_time_s": 100.0,
        "wall_time_s": 2.0,
        "invariants": {name: True for name in INVARIANTS},
        "violations": {},
    }


def test_the_summary_has_a_row_per_robot_and_a_table_per_robot():
    from rich.console import Console

    summary = summarise([_record("pr2", 1, 5), _record("panda", 1, 3), _record("pr2", 2, 4)])
    rows = {r["robot"]: r for r in summary["rows"]}
    assert rows["pr2"]["delivered_rate"] == pytest.approx(9 / 10)
    assert rows["panda"]["delivered_rate"] == pytest.approx(3 / 5)
    assert (rows["pr2"]["runs"], rows["panda"]["runs"]) == (2, 1)
    console = Console(width=80, record=True, color_system=None)
    console.print(summary_table(summary))
    lines = console.export_text().splitlines()
    assert max(len(line) for line in lines) <= 80
    assert not any("…" in line for line in lines)  # nothing truncated
    titles = [line.strip() for line in lines if "robustness campaign" in line]
    assert titles == [
        "robustness campaign (true world, panda)",
        "robustness campaign (true world, pr2)",
    ]
    body = [line.split()[:4] for line in lines if line.strip().startswith("yes")]
    assert body == [["yes", "0.10", "1", "60.0"], ["yes", "0.10", "2", "90.0"]]


def test_a_record_from_before_robots_were_a_choice_counts_as_the_pr2s():
    old = _record("pr2", 1, 5)
    del old["robot"]
    (row,) = summarise([old])["rows"]
    assert row["robot"] == "pr2"


def test_the_benchmark_report_has_a_robot_column(tmp_path):
    import json

    from aiocram.bench import _campaign_markdown

    summary = summarise([_record("pr2", 1, 5), _record("panda", 1, 4)])
    (tmp_path / "campaign.json").write_text(json.dumps({"summary": summary, "runs": []}))
    text = _campaign_markdown(tmp_path)
    assert "| panda | yes | 0.10 | 1 | 80.0 % |" in text
    assert "| pr2 | yes | 0.10 | 1 | 100.0 % |" in text


def test_a_crashed_run_records_its_robot(monkeypatch):
    import aiocram.demo
    from aiocram.campaign import Job, run_job

    def crash(**_):
        raise RuntimeError("boom")

    monkeypatch.setattr(aiocram.demo, "run_demo_once", crash)
    record = run_job(Job(seed=1, fault_rate=0.0, projection=False, robot="panda"))
    assert (record["robot"], record["error"]) == ("panda", "RuntimeError: boom")


def test_a_campaign_run_records_its_robot(tmp_path):
    """A real (short) campaign with the PR2: its record and its summary row carry it."""
    from aiocram.campaign import run_campaign

    results = run_campaign(
        seeds=1,
        faults=[0.0],
        projection_modes=(False,),
        objects=("cup",),
        robots="pr2",
    )
    (record,) = results
    assert "error" not in record, record.get("error")
    assert record["robot"] == "pr2"
    assert [r["robot"] for r in summarise(results)["rows"]] == ["pr2"]


def _panda_body_loads() -> bool:
    """Whether the projection loads the Panda's own body (the projection's part of issue
    25): until then ``World(robot=panda)`` holds the PR2-like body."""
    from projection import World

    with World(seed=0, robot=PANDA) as world:
        try:
            world.link_aabb(PANDA.arms[0].hand_link)
        except (KeyError, LookupError, ValueError):
            return False
    return True


needs_panda_body = pytest.mark.skipif(
    not _panda_body_loads(),
    reason="needs the projection to load the Panda's body (issue 25, projection part)",
)


@needs_panda_body
def test_a_campaign_with_two_robots_runs_each_cell_per_robot():
    """After the projection's Panda is merged: a real campaign, both robots, one cell."""
    from aiocram.campaign import run_campaign

    results = run_campaign(
        seeds=1,
        faults=[0.0],
        projection_modes=(False,),
        objects=("cup",),
        robots="pr2,panda",
    )
    assert sorted(r["robot"] for r in results) == ["panda", "pr2"]
    assert not [r["error"] for r in results if "error" in r]
    rows = summarise(results)["rows"]
    assert sorted(r["robot"] for r in rows) == ["panda", "pr2"]
    assert all(r["runs"] == 1 and r["objects"] == 1 for r in rows)


# ------------------------------------------------------------------ truth, footprint
def test_the_arm_of_a_held_link_comes_from_the_description():
    from aiocram.truth import _arm_links, _holding_arm

    pr2 = _arm_links(PR2)
    assert _holding_arm(PR2.arm("right").hand_link, pr2) == "right"
    assert _holding_arm(PR2.arm("left").tool_frame, pr2) == "left"
    assert _holding_arm(PR2.base_link, pr2) is None
    panda = _arm_links(PANDA)
    assert set(panda) == {"left"}  # one arm
    assert _holding_arm("panda_leftfinger", panda) == "left"
    assert _holding_arm(PANDA.arms[0].hand_link, panda) == "left"
    assert _holding_arm(PANDA.torso.joint, panda) is None


def test_arm_errors_are_per_arm_of_the_description():
    from aiocram.truth import _arm_error

    arm = PANDA.arms[0]
    limits = tuple((j, -2.9, 2.9) for j in arm.joints)  # the Panda has no continuous joint
    at_park = SimpleNamespace(
        robot=PANDA,
        arm_joints=lambda name: arm.state("park"),
        arm_joint_limits=lambda name: limits,
    )
    assert _arm_error(at_park, "park") == {"left": 0.0}
    carry = max(abs(a - b) for a, b in zip(arm.state("park"), arm.state("carry"), strict=True))
    assert _arm_error(at_park, "carry") == {"left": pytest.approx(carry)}


def _box_world(half_x, half_y, yaw):
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    ex, ey = half_x * c + half_y * s, half_x * s + half_y * c
    pose = SimpleNamespace(yaw=yaw)
    return SimpleNamespace(
        robot=PR2,
        link_aabb=lambda link: ((1.0 - ex, 2.0 - ey, 0.0), (1.0 + ex, 2.0 + ey, 0.3)),
        robot_pose=lambda: pose,
    )


@pytest.mark.parametrize("yaw", [0.0, 0.3, -1.2, math.pi / 2, 2.8])
def test_the_costmap_footprint_is_the_base_links_extent(yaw):
    from aiocram._costmap_figure import base_half_extents

    assert base_half_extents(_box_world(0.4, 0.25, yaw)) == pytest.approx((0.4, 0.25))


def test_the_pr2s_footprint_is_its_base_box():
    from aiocram._costmap_figure import base_half_extents
    from projection import World

    with World(seed=0) as world:
        assert base_half_extents(world) == pytest.approx((0.326, 0.326), abs=1e-3)


def test_the_plots_draw_a_line_per_robot_and_mode(tmp_path, monkeypatch):
    import matplotlib.figure

    from aiocram.campaign import _plot

    labels: list[list[str]] = []
    save = matplotlib.figure.Figure.savefig

    def savefig(fig, *args, **kwargs):
        labels.append([t.get_text() for t in fig.axes[0].get_legend().get_texts()])
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    summary = summarise([_record("pr2", 1, 5), _record("panda", 1, 3)])
    assert [p.name for p in _plot(summary, tmp_path)] == ["success_rate.png", "distance.png"]
    assert labels[1] == ["panda, with projection", "pr2, with projection"]
    assert labels[0][0] == "panda, with projection (95 % interval)"


def test_arm_errors_count_a_continuous_joint_the_short_way_round():
    """The PR2's forearm and wrist roll are continuous: an arm at park but for whole turns
    of them (or read a hair past the wrap) is at park."""
    from aiocram.truth import _arm_error
    from projection import World

    with World(seed=0) as world:
        limits = world.arm_joint_limits("right")
    park = robots.pr2.DESCRIPTION.arm("right").state("park")
    turned = tuple(
        v + (2.0 * math.pi if math.isinf(hi) else 0.0) for v, (_j, _lo, hi) in zip(park, limits)
    )
    assert turned != park  # it has continuous joints
    right_only = SimpleNamespace(arms=(robots.pr2.DESCRIPTION.arm("right"),))
    at = SimpleNamespace(
        robot=right_only, arm_joints=lambda name: turned, arm_joint_limits=lambda name: limits
    )
    assert _arm_error(at, "park")["right"] == pytest.approx(0.0, abs=1e-9)
    nudged = (*park[:4], park[4] + 0.3, *park[5:])
    at.arm_joints = lambda name: nudged
    assert _arm_error(at, "park")["right"] == pytest.approx(0.3)
