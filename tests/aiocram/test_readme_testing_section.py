"""The README's "Testing your plans" example is the test file the suite runs, word for word
(so the ten lines a user copies are a passing test)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_readme_testing_example_is_the_tested_file() -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Testing your plans", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, re.S)
    tested = (ROOT / "tests" / "aiocram" / "test_readme_example.py").read_text()
    assert block == tested
