"""No robot in ``plans/`` or ``executive/`` (issue 25): their code (docstrings and comments
aside) never spells a robot's name, a joint or link name of any robot described in the
top-level ``robots`` package, or a fragment such a name is assembled from, and never uses
the PR2-specific constants of :mod:`executive.knowledge`. The plans read all of that from
the environment's :class:`executive.RobotDescription`.

No kitchen either (issue 25, item 2): the same code never spells a link or joint name of
the kitchen (those of the projection's kitchen URDF and every name a description of the
top-level ``kitchens`` package gives); the plans read the kitchen's surfaces, container and
floor from the environment's :class:`executive.KitchenDescription`."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from collections.abc import Iterator
from pathlib import Path

import pytest

import kitchens
import robots
from executive import KinematicTree, KitchenDescription, RobotDescription

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("plans", "executive")

#: The PR2-like robot's constants of :mod:`executive.knowledge`: removed when issue 25 is
#: merged. Until then their definitions there are the only place they may appear.
PR2_CONSTANTS = frozenset(
    {
        "ARMS",
        "ARM_PREFIX",
        "ARM_JOINTS",
        "STANDARD_TO_PR2_ROTATION",
        "GRIPPER_MAX_OPENING",
        "ARM_CONFIGURATIONS",
        "arm_configuration",
        "tool_frame",
        "wrist_link",
        "_prefix",
    }
)
#: Where those definitions live (skipped as a whole, statement by statement).

#: An f-string's literal part at least this long that occurs inside a robot's joint or
#: link name is a name being assembled (``f"{prefix}_gripper_tool_frame"``); shorter ones
#: (``_joint``, ``_gripper``) are the vocabulary every name shares.
FRAGMENT = 10
#: The description contract's module: its strings may name its own fields (``base_link``
#: is a field of :class:`executive.RobotDescription` and a link of most robots).
CONTRACT = Path("executive") / "_robot.py"


def contract_fields() -> frozenset[str]:
    """The field names of the description records."""
    import dataclasses

    import executive

    records = (
        executive.RobotDescription,
        executive.ArmDescription,
        executive.GripperDescription,
        executive.TorsoDescription,
        executive.NeckDescription,
        executive.CameraDescription,
        executive.Reach,
    )
    return frozenset(f.name for r in records for f in dataclasses.fields(r))


def descriptions() -> list[RobotDescription]:
    """Every ``DESCRIPTION`` of a module of the ``robots`` package (by type)."""
    found = []
    for info in pkgutil.iter_modules(robots.__path__):
        module = importlib.import_module(f"robots.{info.name}")
        description = getattr(module, "DESCRIPTION", None)
        if isinstance(description, RobotDescription):
            found.append(description)
    return found


def robot_words() -> frozenset[str]:
    """The robots' names and every joint and link name of their URDFs."""
    words: set[str] = set()
    for d in descriptions():
        tree = KinematicTree.from_urdf(d.urdf())
        words |= {d.name, tree.name, *tree.links, *tree.joints}
    return frozenset(words)


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring nodes (module, class, function)."""
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if (
                body
                and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                ids.add(id(body[0].value))
    return ids


def _defines_pr2_constant(stmt: ast.stmt) -> bool:
    if isinstance(stmt, ast.FunctionDef):
        return stmt.name in PR2_CONSTANTS
    targets: list[ast.expr] = []
    if isinstance(stmt, ast.Assign):
        targets = stmt.targets
    elif isinstance(stmt, ast.AnnAssign):
        targets = [stmt.target]
    return any(isinstance(t, ast.Name) and t.id in PR2_CONSTANTS for t in targets)


def robot_spellings(
    source: str,
    words: frozenset[str],
    legacy: bool = False,
    allowed: frozenset[str] = frozenset(),
    names: frozenset[str] = frozenset({"pr2", "panda"}),
) -> list[str]:
    """``line: what`` of every robot spelling in ``source`` (see the module docstring):
    string literals equal to or prefixed by one of ``words`` (except the ``allowed``
    ones), f-string fragments of them, identifiers equal to a robot's name (``names``),
    uses of :data:`PR2_CONSTANTS`. ``legacy``: skip the top-level definitions of
    :data:`PR2_CONSTANTS` (and ``__all__``)."""
    tree = ast.parse(source)
    if legacy:
        assert isinstance(tree, ast.Module)
        tree.body = [
            s
            for s in tree.body
            if not _defines_pr2_constant(s)
            and not (
                isinstance(s, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "__all__" for t in s.targets)
            )
        ]
    docstrings = _docstrings(tree)
    fragments = {id(v) for n in ast.walk(tree) if isinstance(n, ast.JoinedStr) for v in n.values}
    found: list[str] = []

    def flag(node: ast.AST, what: str) -> None:
        found.append(f"{getattr(node, 'lineno', 0)}: {what}")

    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if id(node) in docstrings:
                continue
            s = node.value
            if s in allowed:
                continue
            if any(s == w or s.startswith(w) for w in words):
                flag(node, repr(s))
            elif id(node) in fragments and len(s) >= FRAGMENT and any(s in w for w in words):
                flag(node, f"fragment {s!r} of a robot's name")
        elif isinstance(node, ast.Name) and (
            node.id.lower() in names
            or (node.id in PR2_CONSTANTS and isinstance(node.ctx, ast.Load))
        ):
            flag(node, node.id)
        elif isinstance(node, ast.Attribute) and node.attr in PR2_CONSTANTS:
            if isinstance(node.value, ast.Name) and node.value.id == "knowledge":
                flag(node, f"knowledge.{node.attr}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").endswith("knowledge"):
            for alias in node.names:
                if alias.name in PR2_CONSTANTS:
                    flag(node, f"from {node.module} import {alias.name}")
    return sorted(set(found), key=lambda f: int(f.split(":")[0]))


def _files(root: Path) -> Iterator[Path]:
    for package in PACKAGES:
        yield from sorted((root / package).rglob("*.py"))


def violations(root: Path, words: frozenset[str]) -> list[str]:
    """``path:line: what`` of every robot spelling in the packages under ``root``."""
    out = []
    names = frozenset(d.name for d in descriptions())
    for path in _files(root):
        rel = path.relative_to(root)
        allowed = contract_fields() if rel == CONTRACT else frozenset()
        found = robot_spellings(path.read_text(), words, allowed=allowed, names=names)
        out += [f"{rel}:{v}" for v in found]
    return out


@pytest.fixture(scope="module")
def words() -> frozenset[str]:
    return robot_words()


def test_the_words_are_the_described_robots(words: frozenset[str]) -> None:
    names = {d.name for d in descriptions()}
    assert {"pr2", "panda"} <= names
    for d in descriptions():
        assert d.base_frame in words and d.arms[0].tool_frame in words
        assert set(d.arms[0].joints) <= words


def test_the_check_finds_the_old_patterns(words: frozenset[str]) -> None:
    old = (
        'ROBOT = "pr2"\n'
        'frame = "base_footprint"\n'
        'link = f"{ARM_PREFIX[arm]}_gripper_tool_frame"\n'
        "joints = knowledge.ARM_JOINTS\n"
        "from executive.knowledge import wrist_link\n"
        'j = "panda_joint1"\n'
        'def f():\n    """The ``l_wrist_roll_link`` in a docstring is fine."""\n'
        'ok = f"{arm}-configuration"  # "left" / "right" are CRAM\'s arm names\n'
    )
    assert [int(v.split(":")[0]) for v in robot_spellings(old, words)] == [1, 2, 3, 3, 4, 5, 6]


def test_the_pr2_constants_of_knowledge_are_skipped_only_where_defined(
    words: frozenset[str],
) -> None:
    source = 'def wrist_link(arm):\n    return f"{arm}_wrist_roll_link"\nuse = ARMS\n'
    assert [int(v.split(":")[0]) for v in robot_spellings(source, words, legacy=True)] == [3]
    assert [int(v.split(":")[0]) for v in robot_spellings(source, words)] == [2, 3]


def test_plans_and_executive_spell_no_robot(words: frozenset[str]) -> None:
    found = violations(ROOT, words)
    assert not found, (
        "plans/ and executive/ must read the robot from current_environment().robot "
        "(an executive.RobotDescription), never spell it:\n" + "\n".join(found)
    )


# ---------------------------------------------------------------------------- kitchens
def kitchen_descriptions() -> list[KitchenDescription]:
    """Every ``DESCRIPTION`` of a module of the ``kitchens`` package (by type)."""
    found = []
    for info in pkgutil.iter_modules(kitchens.__path__):
        module = importlib.import_module(f"kitchens.{info.name}")
        description = getattr(module, "DESCRIPTION", None)
        if isinstance(description, KitchenDescription):
            found.append(description)
    return found


def kitchen_words() -> frozenset[str]:
    """Every link and joint name of the projection's kitchen URDF, and every link or joint
    a kitchen description names (the kitchen's body name, CRAM's ``kitchen``, is the
    role designators say ``part-of``, not a link: it is not one of them)."""
    from projection._world_base import ASSETS

    tree = KinematicTree.from_urdf(ASSETS / "kitchen.urdf")
    words = {*tree.links, *tree.joints}
    for d in kitchen_descriptions():
        c = d.container
        words |= {d.start_surface, d.table_surface, c.link, c.joint, c.handle}
        words |= set(d.demo_attachments.values())
    return frozenset(words)


def kitchen_violations(root: Path, words: frozenset[str]) -> list[str]:
    """``path:line: what`` of every kitchen link or joint spelt in the packages under
    ``root``."""
    out = []
    for path in _files(root):
        found = robot_spellings(path.read_text(), words, names=frozenset())
        out += [f"{path.relative_to(root)}:{v}" for v in found]
    return out


def test_the_kitchen_words_are_the_described_kitchens() -> None:
    found = kitchen_descriptions()
    assert found, "the kitchens package describes no kitchen"
    words = kitchen_words()
    for d in found:
        assert {d.start_surface, d.table_surface, d.container.link, d.container.joint} <= words
    assert "kitchen" not in words  # the role word, not a link


def test_the_check_finds_kitchen_names() -> None:
    old = (
        'SINK_SURFACE = "sink_area_surface"\n'
        'DRAWER_JOINT = f"{DRAWER_LINK}_joint"\n'
        'handle = f"{side}_upper_drawer_handle"\n'
        'on = an.object(type="counter-top", urdf_name=k.start_surface, part_of=k.name)\n'
        'def f():\n    """The ``kitchen_island_surface`` in a docstring is fine."""\n'
    )
    found = robot_spellings(old, kitchen_words(), names=frozenset())
    assert [int(v.split(":")[0]) for v in found] == [1, 3]


def test_plans_and_executive_spell_no_kitchen() -> None:
    found = kitchen_violations(ROOT, kitchen_words())
    assert not found, (
        "plans/ and executive/ must read the kitchen from current_environment().kitchen "
        "(an executive.KitchenDescription), never spell its links:\n" + "\n".join(found)
    )
