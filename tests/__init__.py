"""The test suite, a package so that test modules import shared helpers by their full name
(``from tests.cpl.fake_tasks import FakeTask``, ``from .docs_blocks import ...``) for pytest
and mypy alike. Its subdirectories stay plain directories: a ``tests/cpl`` package would
shadow the real ``cpl`` whenever ``tests/`` is on ``sys.path`` (``python tests/docs_blocks.py``)."""
