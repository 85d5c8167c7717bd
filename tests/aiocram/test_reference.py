"""The designator reference (``aiocram reference``) is generated from the rules' RuleDocs:
every rule has one, the retry counts they state are the counts the plans' counters grant,
the keys they list are the keys the executive accepts, and docs/robot_plans.md holds the
reference as generated now (regenerate with ``python -m aiocram.cli reference --update
docs/robot_plans.md``)."""

from __future__ import annotations

import ast
import importlib
import inspect
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import executive
from aiocram.cli import main
from aiocram.reference import (
    END,
    START,
    UndocumentedRule,
    designator_reference,
    projection_rules,
    replace_section,
    undocumented,
)
from executive import Key, Retry, RuleDoc, RuleSet

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "robot_plans.md"


@pytest.fixture(scope="module")
def rules() -> RuleSet:
    return projection_rules()


def _documented(rules: RuleSet) -> Iterator[tuple[str, str, Any]]:
    for kind in ("action", "motion"):
        for type_, found in rules.documented_rules(kind).items():
            for r in found:
                yield kind, type_, r


# ------------------------------------------------------------------------ completeness
def test_every_rule_of_the_projected_robot_is_documented(rules: RuleSet) -> None:
    assert undocumented(rules) == []
    kinds = {kind for kind, _, _ in _documented(rules)}
    assert kinds == {"action", "motion"}
    assert len(rules.location_generators()) >= 3  # pose/of, among/then, costmaps


def test_a_rule_without_a_doc_is_reported_and_stops_the_reference(rules: RuleSet) -> None:
    child = rules.child("test")
    child.register("action", "juggling", lambda d: iter(()), keys=("balls",))
    assert undocumented(child) == [
        f"action rule 'juggling' ({__name__}.test_a_rule_without_a_doc_is_reported_and_stops"
        "_the_reference.<locals>.<lambda>)"
    ]
    with pytest.raises(UndocumentedRule, match="juggling"):
        designator_reference(child)


def test_the_committed_reference_is_the_generated_one(rules: RuleSet) -> None:
    text = GUIDE.read_text()
    assert replace_section(text, designator_reference(rules), path=str(GUIDE)) == text, (
        "docs/robot_plans.md's designator reference is stale: run "
        "`python -m aiocram.cli reference --update docs/robot_plans.md` and read the diff"
    )


def test_the_reference_lists_every_type_and_key(rules: RuleSet) -> None:
    reference = designator_reference(rules)
    for kind, type_, r in _documented(rules):
        assert f"#### {kind} `{type_}`" in reference
        for key in r.doc.keys:
            assert f"| `{key.name}` |" in reference
    for g in rules.location_generators():
        assert g.doc is not None
        for key in g.doc.keys:
            assert f"| `{key.name}` |" in reference


# ----------------------------------------------------------------------------- the keys
def test_the_documented_keys_are_the_keys_the_executive_accepts(rules: RuleSet) -> None:
    for kind, type_, r in _documented(rules):
        if r.doc.any_key:
            assert r.keys is None
        else:
            assert r.keys == r.doc.key_names, (kind, type_)
    from projection._locations import _MODIFIERS, COSTMAP_DOC, COSTMAP_KEYS

    assert COSTMAP_DOC.key_names == COSTMAP_KEYS | _MODIFIERS | {"location", "object", "pose"}


def test_performed_types_are_registered(rules: RuleSet) -> None:
    for _kind, type_, r in _documented(rules):
        for performed in r.doc.performs:
            assert rules.rules_for("action", performed), (type_, performed)
        for motion in r.doc.motions:
            assert rules.rules_for("motion", motion), (type_, motion)


def test_the_failures_an_action_names_are_the_ones_its_module_handles(rules: RuleSet) -> None:
    for kind, type_, r in _documented(rules):
        if kind != "action":
            continue
        source = inspect.getsource(importlib.import_module(r.fn.__module__))
        named = {*r.doc.raises, *r.doc.ignores, *(c for t in r.doc.retries for c in t.on)}
        for failure in named:
            assert failure.__name__ in source, (type_, failure.__name__)


# -------------------------------------------------------------------------- the retries
def _values(node: ast.expr, module: ModuleType, scopes: list[ast.AST]) -> set[int] | None:
    """The integer values a counter's count expression can take, or None if unknown: a
    literal, a module constant, a parameter default of an enclosing function, or a
    conditional of those."""
    if isinstance(node, ast.Constant) and isinstance(node.value, int):
        return {node.value}
    if isinstance(node, ast.IfExp):
        body, orelse = _values(node.body, module, scopes), _values(node.orelse, module, scopes)
        return None if body is None or orelse is None else body | orelse
    if isinstance(node, ast.Name):
        for scope in reversed(scopes):
            if isinstance(scope, (ast.FunctionDef, ast.AsyncFunctionDef)):
                args = scope.args
                positional = [*args.posonlyargs, *args.args]
                defaults = (
                    dict(zip([p.arg for p in positional[-len(args.defaults) :]], args.defaults))
                    if args.defaults
                    else {}
                )
                defaults.update(
                    {p.arg: d for p, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None}
                )
                if node.id in defaults:
                    return _values(defaults[node.id], module, [])
        value = getattr(module, node.id, None)
        if isinstance(value, int) and not isinstance(value, bool):
            return {value}
    return None


def counters_in(module: ModuleType) -> dict[str, set[int] | None]:
    """Every ``CountedRetries(count, "name")`` of ``module``: name -> possible counts."""
    found: dict[str, set[int] | None] = {}

    def visit(node: ast.AST, scopes: list[ast.AST]) -> None:
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "CountedRetries"
            and len(node.args) == 2
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
        ):
            values = _values(node.args[0], module, scopes)
            name = node.args[1].value
            known = found.get(name, set())
            found[name] = None if values is None or known is None else known | values
        inner = (
            [*scopes, node] if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) else scopes
        )
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(ast.parse(inspect.getsource(module)), [])
    return found


def retry_mismatches(
    documented: dict[str, list[int]], code: dict[str, set[int] | None]
) -> list[str]:
    """What differs between a module's documented retry counters (name -> counts) and its
    ``CountedRetries`` (name -> possible counts; None: not a constant)."""
    problems = []
    for name, counts in documented.items():
        if name not in code:
            problems.append(f"counter {name!r} is documented but the plans have none")
            continue
        possible = code[name]
        for count in counts:
            if possible is not None and count not in possible:
                problems.append(f"counter {name!r}: documented {count}, the code grants {possible}")
    for name, possible in code.items():
        if possible is not None and name not in documented:
            problems.append(f"counter {name!r} ({possible}) is in the plans but no rule's doc")
    return problems


def test_documented_retry_counts_are_the_plans_counters(rules: RuleSet) -> None:
    by_module: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(list))
    for kind, _type, r in _documented(rules):
        if kind == "action":
            by_module[r.fn.__module__]
            for retry in r.doc.retries:
                if retry.counter is not None:
                    by_module[r.fn.__module__][retry.counter].append(retry.count)
    assert {"plans.atomic", "plans.fetch", "plans.deliver", "plans.search"} <= set(by_module)
    problems = {
        module: retry_mismatches(documented, counters_in(importlib.import_module(module)))
        for module, documented in by_module.items()
    }
    assert {m: p for m, p in problems.items() if p} == {}


def test_the_retry_check_can_fail() -> None:
    module = importlib.import_module("plans.search")
    code = counters_in(module)
    assert code["search"] == {9}  # the plan's default parameter
    assert code["search-torso"] == {1}
    assert counters_in(importlib.import_module("plans.atomic"))["detecting"] == {1, 4}
    assert retry_mismatches({"search": [8], "search-torso": [1]}, code) == [
        "counter 'search': documented 8, the code grants {9}"
    ]
    assert retry_mismatches({"search": [9]}, code) == [
        "counter 'search-torso' ({1}) is in the plans but no rule's doc"
    ]
    assert "documented but the plans have none" in retry_mismatches({"nope": [1]}, {})[0]


# ------------------------------------------------------------------------ bad input
def test_bad_docs_are_refused_at_registration_naming_what_to_fix() -> None:
    with pytest.raises(ValueError, match="lower-case words"):
        Key("Arm!", "str", "the arm")
    with pytest.raises(ValueError, match="required, so it has no default"):
        Key("arm", "str", "the arm", default="left", required=True)
    assert Key("joint_angle", "number", "torso").name == "joint-angle"
    with pytest.raises(TypeError, match="int >= 0"):
        Retry(-1, (executive.PerceptionLowLevelFailure,), "look again")
    with pytest.raises(ValueError, match="at least one failure"):
        Retry(1, (), "look again")
    with pytest.raises(TypeError, match="exception classes"):
        Retry(1, ("perception",), "look again")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="twice"):
        RuleDoc("x", keys=(Key("a", "t", "d"), Key("a", "t", "d")))
    rules = RuleSet()
    doc = RuleDoc("Juggle.", keys=(Key("balls", "int", "how many", required=True),))
    with pytest.raises(ValueError, match="differ from the doc's keys"):
        rules.register("action", "juggling", lambda d: iter(()), keys=("clubs",), doc=doc)
    with pytest.raises(TypeError, match=r"executive\.RuleDoc"):
        rules.register("action", "juggling", lambda d: iter(()), doc="Juggle.")  # type: ignore[arg-type]
    rules.register("action", "juggling", lambda d: iter(()), doc=doc)
    assert rules.lookup("action", "juggling")[1] == frozenset({"type", "balls"})


def test_replace_section_needs_both_markers() -> None:
    with pytest.raises(ValueError, match="exactly once"):
        replace_section("no markers here", "ref", path="x.md")
    text = f"before\n{START}\nold\n{END}\nafter\n"
    assert replace_section(text, "new\n") == f"before\n{START}\n\nnew\n\n{END}\nafter\n"


def test_the_command_checks_and_updates_a_file(tmp_path: Path, capsys: Any) -> None:
    copy = tmp_path / "guide.md"
    copy.write_text(GUIDE.read_text())
    assert main(["reference", "--check", str(copy)]) == 0
    copy.write_text(f"# guide\n{START}\nstale\n{END}\n")
    assert main(["reference", "--check", str(copy)]) == 1
    assert "stale" in capsys.readouterr().err
    assert main(["reference", "--update", str(copy)]) == 0
    assert main(["reference", "--check", str(copy)]) == 0
    (tmp_path / "none.md").write_text("no markers")
    assert main(["reference", "--check", str(tmp_path / "none.md")]) == 2
