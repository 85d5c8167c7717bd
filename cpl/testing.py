"""Test helpers for cpl code.

:class:`MockClock` runs a loop on virtual time: install it with ``cpl.run(fn,
clock=MockClock())``, or by hand on a fresh loop::

    loop = asyncio.new_event_loop()
    clock = MockClock()
    clock.install(loop)
    try:
        loop.run_until_complete(main())
    finally:
        clock.uninstall(loop)
        loop.close()
"""

from __future__ import annotations

from ._clock import MockClock

__all__ = ["MockClock"]
