"""Learning from experience (issue 29): priors learned from a store built by a small real
campaign, saved and loaded as a versioned JSON file, used by ``--learned`` to order the
pick's arm/grasp choices, and bad priors files refused before anything runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import func, select

from aiocram.cli import main
from aiocram.experience import (
    PRIORS_VERSION,
    LearnedPriors,
    PriorsCorruptError,
    PriorsRobotError,
    PriorsVersionError,
    Store,
)
from aiocram.experience._priors import ChoiceStats, Prior, base_in_object
from aiocram.experience._schema import parameters

pytestmark = pytest.mark.timeout(900)


@pytest.fixture(scope="module")
def learned(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """``campaign --seeds 2 --faults 0,0.1 --no-projection --objects cup bowl``, then
    ``experience learn`` on its store."""
    out = tmp_path_factory.mktemp("learn") / "c"
    args = ["--objects", "cup", "bowl", "--workers", "2", "--no-projection", "--out", str(out)]
    assert main(["campaign", "--seeds", "2", "--faults", "0,0.1", *args]) in (0, 1)
    priors = out / "priors.json"
    store = out / "experience.sqlite"
    assert main(["experience", "learn", "--store", str(store), "--out", str(priors)]) == 0
    return {"store": store, "priors": priors}


def test_priors_are_learned_from_the_real_runs(learned, capsys):
    priors = LearnedPriors.load(learned["priors"])
    assert priors.robot == "pr2" and priors.runs == 4
    with Store(learned["store"]) as store, store.engine.connect() as conn:
        real = conn.execute(
            select(parameters.c.action, parameters.c.object, func.count())
            .where(parameters.c.imagined.is_(False))
            .group_by(parameters.c.action, parameters.c.object)
        ).all()
        ok = conn.execute(
            select(func.count()).where(
                parameters.c.imagined.is_(False),
                parameters.c.status == "SUCCEEDED",
                parameters.c.object == "cup",
                parameters.c.action == "picking-up",
            )
        ).scalar_one()
    for action, obj, n in real:
        prior = priors.lookup(action, obj)
        assert prior is not None and prior.tried == n
        rates = [c.smoothed for c in prior.choices]
        assert rates == sorted(rates, reverse=True)
    cup = priors.lookup("picking-up", "cup")
    assert cup is not None and cup.succeeded == ok == len(cup.samples) > 0
    # the density is highest where the base stood, and falls off away from there
    x, y, yaw = cup.samples[0]
    assert cup.density(x, y, yaw) > cup.density(x + 1.0, y + 1.0, yaw) >= 0.0
    # the base stood in front of the object (within arm's reach of it)
    assert all(0.2 < (sx**2 + sy**2) ** 0.5 < 1.3 for sx, sy, _ in cup.samples)
    # a round trip through the file changes nothing
    again = LearnedPriors.from_json(json.loads(json.dumps(priors.to_json())))
    assert again == priors


def test_the_learn_command_shows_what_it_learned(learned, capsys, tmp_path):
    out = tmp_path / "p.json"
    assert main(["experience", "learn", "--store", str(learned["store"]), "--out", str(out)]) == 0
    shown = capsys.readouterr().out
    assert "learned priors for pr2 (4 runs)" in shown and "cup" in shown and str(out) in shown
    assert json.loads(out.read_text())["version"] == PRIORS_VERSION


def test_laplace_smoothing_keeps_a_lucky_try_below_a_long_record():
    lucky = ChoiceStats("left", "top", tried=1, succeeded=1)
    proven = ChoiceStats("right", "front", tried=20, succeeded=18)
    prior = Prior("picking-up", "cup", "counter", (proven, lucky))
    priors = LearnedPriors("pr2", (prior,))
    choices = [("left", "top"), ("left", "back"), ("right", "front")]
    # 19/22 before 2/3 before the untried 1/2
    assert priors.order_choices("picking-up", "cup", choices) == [
        ("right", "front"),
        ("left", "top"),
        ("left", "back"),
    ]
    assert priors.order_choices("picking-up", "bowl", choices) == choices  # nothing learned


def test_the_base_pose_in_the_object_frame_inverts_the_object_in_the_base_frame():
    # object 0.6 m ahead of the base, turned by 90 degrees: the base is 0.6 m to its -y
    x, y, yaw = base_in_object(0.6, 0.0, 1.5707963267948966)
    assert (x, y, yaw) == pytest.approx((0.0, 0.6, -1.5707963267948966))


def _write_priors(path: Path, choices: list[list[Any]], robot: str = "pr2") -> Path:
    data = {
        "format": "aiocram-learned-priors",
        "version": PRIORS_VERSION,
        "robot": robot,
        "runs": 1,
        "source": "test",
        "priors": [
            {
                "action": "picking-up",
                "object": "cup",
                "surface": None,
                "choices": choices,
                "samples": [],
            }
        ],
    }
    path.write_text(json.dumps(data))
    return path


def _first_pick_arm(out: Path) -> str:
    with Store(out / "experience.sqlite") as store, store.engine.connect() as conn:
        return str(
            conn.execute(
                select(parameters.c.arm)
                .where(parameters.c.action == "picking-up", parameters.c.imagined.is_(False))
                .order_by(parameters.c.node_idx)
                .limit(1)
            ).scalar_one()
        )


def test_the_demo_picks_with_the_arm_experience_favours(tmp_path, capsys):
    """The rules try the right arm first; priors where the right arm always failed and
    the left one always succeeded make the demo's first pick a left-arm one."""
    from executive import knowledge

    grasps = knowledge.grasps("cup")
    priors = _write_priors(
        tmp_path / "p.json",
        [["right", g, 20, 0] for g in grasps] + [["left", g, 20, 20] for g in grasps],
    )
    args = ["demo", "--objects", "cup", "--no-projection", "--runs", "1", "--no-live"]
    assert main([*args, "--out", str(tmp_path / "plain")]) in (0, 1)
    assert main([*args, "--out", str(tmp_path / "learned"), "--learned", str(priors)]) in (0, 1)
    capsys.readouterr()
    assert _first_pick_arm(tmp_path / "plain") == "right"
    assert _first_pick_arm(tmp_path / "learned") == "left"


@pytest.mark.parametrize(
    ("content", "error", "message"),
    [
        (
            {"format": "aiocram-learned-priors", "version": PRIORS_VERSION + 1},
            PriorsVersionError,
            "this aiocram reads up to",
        ),
        ("{not json", PriorsCorruptError, "is not JSON"),
        ({"some": "json"}, PriorsCorruptError, "not a learned-priors file"),
        (
            {"format": "aiocram-learned-priors", "version": 1, "robot": "pr2", "priors": [{}]},
            PriorsCorruptError,
            "is corrupt",
        ),
    ],
)
def test_bad_priors_files_are_refused_before_anything_runs(
    tmp_path, capsys, content, error, message
):
    path = tmp_path / "p.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    with pytest.raises(error, match=message):
        LearnedPriors.load(path)
    demo = ["demo", "--objects", "cup", "--no-live", "--out", str(tmp_path / "d")]
    assert main([*demo, "--learned", str(path)]) == 2
    assert message in capsys.readouterr().err
    campaign = ["campaign", "--seeds", "1", "--faults", "0", "--out", str(tmp_path / "c")]
    assert main([*campaign, "--learned", str(path)]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "d").exists() and not (tmp_path / "c").exists()


def test_priors_of_another_robot_are_refused(tmp_path, capsys):
    path = _write_priors(tmp_path / "p.json", [["right", "top", 1, 1]], robot="tiago")
    with pytest.raises(PriorsRobotError, match="learned for robot 'tiago'"):
        LearnedPriors.load(path).check_robot("pr2")
    out = tmp_path / "d"
    assert main(["demo", "--no-live", "--out", str(out), "--learned", str(path)]) == 2
    assert "learned for robot 'tiago', not 'pr2'" in capsys.readouterr().err
    assert not out.exists()
