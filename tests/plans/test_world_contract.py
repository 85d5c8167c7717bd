"""Plans reach the world only through the world contract (issue 23, item 6): no ``getattr``
/ ``hasattr`` probing of a world, no unwrapping of what a world model wraps; optional
capabilities are runtime-checkable protocols of ``executive`` that ``projection``
implements and plans test with ``isinstance``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import executive
import plans  # registers the action rules (and PLANS below)
from executive import (
    ContainerStates,
    ObjectInventory,
    ObjectSpawning,
    Pose,
    ProjectionWorld,
    a,
    an,
)
from executive.testing import InMemoryWorld

PLANS = Path(plans.__file__).parent


def _mentions_world(node: ast.AST) -> bool:
    return any(
        (isinstance(n, ast.Name) and "world" in n.id.lower())
        or (isinstance(n, ast.Attribute) and "world" in n.attr.lower())
        for n in ast.walk(node)
    )


def _offences(source: str) -> list[tuple[int, str]]:
    """``getattr``/``hasattr`` whose object mentions a world, and ``<x>.world.world``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "hasattr")
            and node.args
            and _mentions_world(node.args[0])
        ):
            found.append((node.lineno, ast.unparse(node)))
        if (
            isinstance(node, ast.Attribute)
            and node.attr == "world"
            and isinstance(node.value, ast.Attribute)
            and node.value.attr == "world"
        ):
            found.append((node.lineno, ast.unparse(node)))
        # getattr(world, "world", ...) spelled through a tuple of candidates, as the old
        # plans did: any string constant "world" handed to getattr
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "hasattr")
            and len(node.args) > 1
            and isinstance(node.args[1], ast.Constant)
            and node.args[1].value in ("world", "container_state")
        ):
            found.append((node.lineno, ast.unparse(node)))
    return found


def test_the_scan_finds_what_the_old_plans_did() -> None:
    """The checker itself can fail: the patterns issue 23 found in ``plans/``."""
    old = (
        "def f(world, env):\n"
        "    for c in (world, getattr(world, 'world', None)):\n"
        "        pass\n"
        "    s = getattr(current_environment().world, 'container_state', None)\n"
        "    w = getattr(current_environment(), 'world', None)\n"
        "    return env.world.world\n"
    )
    assert len({line for line, _ in _offences(old)}) == 4


def test_plans_never_probe_or_unwrap_the_world() -> None:
    offences = {
        f"{path.relative_to(PLANS.parent)}:{line}": text
        for path in sorted(PLANS.rglob("*.py"))
        for line, text in _offences(path.read_text())
    }
    assert not offences, (
        "plans/ must ask the world only what executive's world protocols say (test optional "
        f"capabilities with isinstance against an executive protocol): {offences}"
    )


def test_an_environment_without_a_world_model_skips_the_place_check() -> None:
    """``_check_places`` means to skip its check when there is no world model; reading
    ``Environment.world`` there raises ``NoWorldModel`` (a ``LookupError``, which
    ``getattr``'s default does not catch), so the action's rule failed to resolve."""
    from kitchens.iai import DESCRIPTION as kitchen
    from plans.demo import start_surface, table_surface

    SINK, ISLAND = start_surface(kitchen), table_surface(kitchen)

    transport = an.action(
        type="transporting",
        object=an.object(type="bowl"),
        location=a.location(on=SINK),
        target=a.location(on=ISLAND),
    )

    async def resolve() -> object:
        async with executive.environment(executive.Environment("no world")):
            assert not executive.current_environment().has_world
            return transport.reference()

    import cpl

    grounding = cpl.run(resolve)
    assert grounding.arguments["target"].get("on") is ISLAND


def test_the_place_check_still_runs_with_a_world_model() -> None:
    """The guard skips only without a world: an unknown surface is still refused."""
    nowhere = an.object(type="counter-top", urdf_name="nowhere_surface")
    transport = an.action(
        type="transporting",
        object=an.object(type="bowl"),
        location=a.location(on=nowhere),
        target=a.location(pose=Pose((1.0, 0.0, 0.9))),
    )
    world = InMemoryWorld(objects={"bowl-1": Pose((1.0, 0.0, 0.9))})

    async def resolve() -> object:
        async with executive.environment(executive.Environment("fake", world=world)):
            return transport.reference()

    import cpl

    with pytest.raises(executive.DesignatorError, match="nowhere_surface"):
        cpl.run(resolve)


def test_the_in_memory_fake_has_none_of_the_optional_capabilities() -> None:
    world = InMemoryWorld()
    assert isinstance(world, ProjectionWorld)
    for protocol in (ContainerStates, ObjectInventory, ObjectSpawning):
        assert not isinstance(world, protocol), protocol


def test_projection_world_models_implement_the_protocols() -> None:
    projection = pytest.importorskip("projection")
    from projection import ProjectedWorldModel, RealWorldModel, make_world_pair

    true_world, belief_world = make_world_pair(1, objects={})
    try:
        belief_world.spawn_object("cup-1", "cup", Pose((1.4, 0.8, 0.9)))
        projected = ProjectedWorldModel(belief_world)
        real = RealWorldModel(true_world, belief_world)
        for model in (projected, real):
            assert isinstance(model, ContainerStates)
            assert isinstance(model, ObjectInventory)
            assert list(model.object_names()) == ["cup-1"]
            position, lower, upper = model.container_state("sink_area_left_upper_drawer_main")
            assert lower <= position <= upper and upper > lower
        # stand-ins only in an imagined (projected) world: reality is not spawned into
        assert isinstance(projected, ObjectSpawning)
        assert not isinstance(real, ObjectSpawning)
        projected.spawn_object("stand-in", "cup", Pose((1.4, 1.1, 0.9)))
        assert "stand-in" in projected.object_names()
        projected.remove_object("stand-in")
        assert projected.object_names() == ["cup-1"]
        del projection
    finally:
        true_world.close()
        belief_world.close()
