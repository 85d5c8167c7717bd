"""Import PyBullet without its banner.

PyBullet's C module prints ``pybullet build time: ...`` to the process's standard error
(file descriptor 2, below Python's ``sys.stderr``) when it is first imported: noise in
every command and script. :func:`import_pybullet_quietly` imports it with descriptor 2
pointed at ``/dev/null`` for that moment only; errors of the import itself still raise.
"""

from __future__ import annotations

import os
import sys
from types import ModuleType
from typing import cast

__all__ = ["import_pybullet_quietly"]


def import_pybullet_quietly() -> ModuleType:
    """``import pybullet``, without the build-time banner (see the module docstring)."""
    module = sys.modules.get("pybullet")
    if module is not None:
        return module
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real descriptor 2 (embedded): nothing to hide
        import pybullet

        return cast(ModuleType, pybullet)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        import pybullet
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)
    return cast(ModuleType, pybullet)
