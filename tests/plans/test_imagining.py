"""``plans.imagine_best``: imagine named alternatives, run the best (issue 14), on the
fakes of ``test_reasoning`` (a fake real robot that imagines on the same in-memory world)."""

from __future__ import annotations

from typing import Any

import pytest
from test_reasoning import child, cpl_walk, run_real, setup  # type: ignore[import-not-found]

import cpl
from executive import a, an, perform, performed
from plans.imagining import Imagined, by_success_then_time, imagine_best


def _transport(object_type: str) -> Any:
    async def go() -> Any:
        return await perform(
            an.action(
                type="transporting",
                object=an.object(type=object_type),
                location=a.location(spots=1),
                target=a.location(spots=5),
            )
        )

    return go


def test_the_order_of_transports_is_chosen_by_projection():
    """The plate is not there (its imagined transport fails), so the cup goes first even
    though the plate is listed first; the real run is the chosen subtree."""
    world, real, _dream, imagination = setup()

    async def body() -> Any:
        return await imagine_best({"plate": _transport("plate"), "cup": _transport("cup")})

    root, result = run_real(real, imagination, body)
    assert result is not None and world.attached() == []
    plate, cup = child(root, "imagine-plate"), child(root, "imagine-cup")
    assert plate.annotations["imagined"].outcome == "ObjectNowhereToBeFound"
    assert cup.annotations["imagined"].succeeded
    chosen = child(root, "chosen-cup")
    assert [t.name for t in cpl_walk(root) if t.name.startswith("chosen-")] == ["chosen-cup"]
    # the real run is the one that transported the cup for real
    assert chosen.state is cpl.Status.SUCCEEDED
    (_task, transported), *_ = performed(chosen, "transporting")
    assert transported.get("object").get("type") == "cup"
    assert [a.name for a in chosen.annotations["alternatives"]] == ["plate", "cup"]
    assert "plate: ObjectNowhereToBeFound" in chosen.annotations["why"]


def test_a_cheaper_alternative_wins_when_both_succeed():
    _world, real, _dream, imagination = setup()

    def score(imagined: Imagined) -> Any:
        # a plan writer's score: prefer the alternative named "b" unless it fails
        return (not imagined.succeeded, imagined.name != "b")

    async def body() -> Any:
        return await imagine_best({"a": _transport("cup"), "b": _transport("cup")}, score)

    root, _ = run_real(real, imagination, body)
    assert child(root, "chosen-b").state is cpl.Status.SUCCEEDED
    assert by_success_then_time(child(root, "imagine-a").annotations["imagined"])[0] is False


@pytest.mark.parametrize("projecting", [True, False])
def test_inside_projection_or_disabled_it_is_a_pass_through(projecting):
    world, real, _dream, imagination = setup()

    async def body() -> Any:
        return await imagine_best(
            {"plate": _transport("plate"), "cup": _transport("cup")}, enabled=projecting
        )

    with pytest.raises(cpl.PlanFailure):  # the first alternative runs, nothing imagined
        run_real(real, imagination, body, projecting=projecting)
    assert imagination.taken == []  # no snapshot: nothing was imagined
    del world


def test_bad_alternatives_are_refused_before_anything_runs():
    _world, real, _dream, imagination = setup()

    async def empty() -> Any:
        return await imagine_best({})

    with pytest.raises(ValueError, match="at least one alternative"):
        run_real(real, imagination, empty)

    async def unnamed() -> Any:
        return await imagine_best({"": _transport("cup")})

    with pytest.raises(ValueError, match="non-empty strings"):
        run_real(real, imagination, unnamed)
    assert imagination.taken == []
