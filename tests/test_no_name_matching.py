"""No reader of the task tree tells imagined, real and chosen subtrees apart by their
names (issue 24): the code (docstrings and comments aside) never compares, prefix-matches
or lists the reasoning subtrees' names; it reads their :class:`cpl.Subtree` mark."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("cpl", "executive", "projection", "plans", "aiocram")
#: the reasoning subtrees' names (``projection-run-<i>``, ``imagine-<name>``,
#: ``real-run``, ``chosen-<name>``) and their prefixes
NAMES = ("projection-run", "imagine-", "real-run", "chosen-")


def _is_name(value: object) -> bool:
    return isinstance(value, str) and value.startswith(NAMES)


def name_matches(source: str) -> list[tuple[int, str]]:
    """``(line, code)`` of every use of a subtree name as something to match against: an
    operand of a comparison (``==``, ``in``), an argument of ``startswith`` / ``endswith``
    or an element of a tuple, list or set literal (a prefix table). Making a subtree with
    that name (``cpl.tag(f"projection-run-{i}", ...)``) is fine."""
    tree = ast.parse(source)
    found: list[tuple[int, str]] = []

    def strings(node: ast.AST) -> list[ast.Constant]:
        return [n for n in ast.walk(node) if isinstance(n, ast.Constant) and _is_name(n.value)]

    for node in ast.walk(tree):
        suspects: list[ast.Constant] = []
        if isinstance(node, ast.Compare):
            for operand in (node.left, *node.comparators):
                suspects += strings(operand)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in ("startswith", "endswith", "removeprefix"):
                for arg in node.args:
                    suspects += strings(arg)
        elif isinstance(node, ast.Tuple | ast.List | ast.Set):
            suspects += [e for e in node.elts if isinstance(e, ast.Constant) and _is_name(e.value)]
        found += [(s.lineno, ast.get_source_segment(source, s) or "") for s in suspects]
    return sorted(set(found))


def test_the_check_finds_the_old_patterns() -> None:
    old = (
        '_IMAGINED = ("projection-run", "imagine-")\n'
        'if task.name.startswith(_IMAGINED) or t.name.startswith("projection-run"):\n'
        '    real = [c for c in kids if c.name == "real-run"]\n'
        'run = cpl.tag(f"projection-run-{i}", body())  # making one is fine\n'
        'def f():\n    """A ``real-run`` subtree."""\n'
    )
    assert [line for line, _ in name_matches(old)] == [1, 1, 2, 3]


@pytest.mark.parametrize("package", PACKAGES)
def test_no_code_matches_a_subtree_by_its_name(package: str) -> None:
    offenders = [
        f"{path.relative_to(ROOT)}:{line}: {code}"
        for path in sorted((ROOT / package).rglob("*.py"))
        for line, code in name_matches(path.read_text(encoding="utf-8"))
    ]
    assert not offenders, "match the cpl.Subtree mark, not the name:\n" + "\n".join(offenders)
