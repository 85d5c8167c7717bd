"""``python -m aiocram``: the ``aiocram`` command (:func:`aiocram.cli.main`)."""

from __future__ import annotations

import sys

from aiocram.cli import main

if __name__ == "__main__":
    sys.exit(main())
