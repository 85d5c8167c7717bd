"""Clocks: virtual time on an asyncio loop (MockClock, ScaledClock, SystemClock)."""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Awaitable, Callable
from typing import Any, TypeVar

import pytest

import cpl
from cpl._clock import Clock, ScaledClock, SystemClock
from cpl.testing import MockClock

R = TypeVar("R")


def run(fn: Callable[[], Awaitable[R]], clock: Clock) -> R:
    loop = asyncio.new_event_loop()
    clock.install(loop)
    try:
        return loop.run_until_complete(fn())
    finally:
        loop.run_until_complete(loop.shutdown_default_executor())
        clock.uninstall(loop)
        loop.close()


def test_long_sleep_is_instant_in_virtual_time() -> None:
    clock = MockClock()

    async def main() -> tuple[float, float]:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await asyncio.sleep(1000)
        return t0, loop.time()

    t0, t1 = run(main, clock)
    assert t0 == 0.0
    assert t1 - t0 >= 1000
    assert clock.now() == t1


def test_timer_order_is_preserved() -> None:
    async def main() -> list[tuple[str, float]]:
        loop = asyncio.get_running_loop()
        events: list[tuple[str, float]] = []

        async def sleeper(name: str, delay: float) -> None:
            await asyncio.sleep(delay)
            events.append((name, loop.time()))

        loop.call_later(250, lambda: events.append(("timer", loop.time())))
        await asyncio.gather(sleeper("c", 300), sleeper("a", 5), sleeper("b", 60.5))
        return events

    events = run(main, MockClock())
    assert [name for name, _ in events] == ["a", "b", "timer", "c"]
    assert [t for _, t in events] == [5, 60.5, 250, 300]


def test_start_time() -> None:
    async def main() -> float:
        await asyncio.sleep(1)
        return asyncio.get_running_loop().time()

    assert run(main, MockClock(start=100.0)) == 101.0


def test_timeouts_fire_in_virtual_time() -> None:
    async def main() -> float:
        loop = asyncio.get_running_loop()
        with pytest.raises(TimeoutError):
            await asyncio.wait_for(asyncio.Event().wait(), timeout=3600)
        return loop.time()

    assert run(main, MockClock()) >= 3600


@pytest.mark.parametrize("start", [0.0, 1.7e9, 1e15])
@pytest.mark.parametrize("autojump", [True, False])
def test_huge_start_still_makes_progress(start: float, autojump: bool) -> None:
    """Float time is coarse at large values; timers due "now" must still fire."""

    async def main() -> float:
        loop = asyncio.get_running_loop()
        fired = asyncio.Event()
        loop.call_later(0, fired.set)
        await fired.wait()
        if autojump:
            await asyncio.sleep(1e-9)
            await asyncio.sleep(1)
        return loop.time()

    assert run(main, MockClock(autojump=autojump, start=start)) >= start + (1 if autojump else 0)


def test_manual_jump_inside_the_loop() -> None:
    clock = MockClock(autojump=False)

    async def main() -> float:
        loop = asyncio.get_running_loop()
        sleeping = asyncio.create_task(asyncio.sleep(10))
        await asyncio.sleep(0)
        clock.jump(4)
        assert loop.time() == 4
        clock.jump(6)
        await sleeping
        return loop.time()

    assert run(main, clock) == 10


def test_manual_jump_from_another_thread_wakes_the_loop() -> None:
    clock = MockClock(autojump=False)
    started = threading.Event()

    def jumper() -> None:
        started.wait()
        clock.jump(30)

    async def main() -> float:
        loop = asyncio.get_running_loop()
        thread = threading.Thread(target=jumper)
        thread.start()
        loop.call_soon(started.set)
        await asyncio.sleep(30)
        thread.join()
        return loop.time()

    assert run(main, clock) == 30


def test_jump_validation_and_now_without_loop() -> None:
    clock = MockClock(start=5)
    assert clock.now() == 5
    clock.jump(2)
    assert clock.now() == 7
    with pytest.raises(ValueError, match="cannot go backwards"):
        clock.jump(-1)
    with pytest.raises(ValueError):
        clock.jump(math.nan)
    with pytest.raises(ValueError, match="autojump_threshold"):
        MockClock(autojump_threshold=-1)


def test_autojump_threshold_lets_threads_finish_first() -> None:
    async def main() -> float:
        loop = asyncio.get_running_loop()
        await asyncio.wait_for(asyncio.to_thread(time.sleep, 0.01), timeout=1)
        return loop.time()

    assert run(main, MockClock(autojump_threshold=60)) < 1


def test_io_ready_is_not_skipped() -> None:
    """A socket echo round trip completes before a virtual timeout (threshold lets the
    server's I/O arrive)."""

    async def echo(r: asyncio.StreamReader, w: asyncio.StreamWriter) -> None:
        w.write(await r.read(1))
        await w.drain()
        w.close()

    async def main() -> bytes:
        server = await asyncio.start_server(echo, "127.0.0.1", 0)
        try:
            host, port = server.sockets[0].getsockname()[:2]
            reader, writer = await asyncio.open_connection(host, port)
            writer.write(b"x")
            await writer.drain()
            data = await asyncio.wait_for(reader.read(1), timeout=100)
            writer.close()
            await writer.wait_closed()
            return data
        finally:
            server.close()
            await server.wait_closed()

    assert run(main, MockClock(autojump_threshold=60)) == b"x"


def test_install_and_uninstall() -> None:
    clock = MockClock()
    loop = asyncio.new_event_loop()
    other = asyncio.new_event_loop()
    try:
        clock.install(loop)
        clock.install(loop)  # idempotent on the same loop
        assert loop.time() == 0.0
        with pytest.raises(RuntimeError, match="one clock per loop"):
            clock.install(other)
        with pytest.raises(ValueError, match="not installed"):
            clock.uninstall(other)
        clock.jump(3)
        clock.uninstall(loop)
        assert "time" not in vars(loop)
        assert loop.time() == pytest.approx(time.monotonic(), abs=60)
        assert clock.now() == 3
        clock.install(other)
        assert other.time() == 3
        clock.uninstall(other)
    finally:
        loop.close()
        other.close()


def test_loop_without_selector_is_refused() -> None:
    class NoSelectorLoop:
        pass

    with pytest.raises(TypeError, match="SelectorEventLoop"):
        MockClock().install(NoSelectorLoop())  # type: ignore[arg-type]


def test_system_clock_is_a_no_op() -> None:
    clock = SystemClock()
    loop = asyncio.new_event_loop()
    try:
        clock.install(loop)
        assert "time" not in vars(loop)
        assert clock.now() == pytest.approx(loop.time(), abs=60)
        clock.uninstall(loop)
    finally:
        loop.close()
    assert repr(clock) == "SystemClock()"


def test_scaled_clock_runs_faster() -> None:
    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await asyncio.sleep(20)
        return loop.time() - t0

    assert run(main, ScaledClock(1000)) >= 20


@pytest.mark.parametrize("factor", [None, math.inf])
def test_scaled_clock_infinite_is_autojump(factor: float | None) -> None:
    async def main() -> float:
        await asyncio.sleep(5000)
        return asyncio.get_running_loop().time()

    clock = ScaledClock(factor)
    assert clock.factor == math.inf
    assert run(main, clock) == 5000


@pytest.mark.parametrize("factor", [0, -1, math.nan])
def test_scaled_clock_bad_factor(factor: Any) -> None:
    with pytest.raises(ValueError, match="MockClock"):
        ScaledClock(factor)


def test_reprs() -> None:
    assert repr(MockClock(start=2)) == "MockClock(autojump=True, now=2.0)"
    assert repr(ScaledClock(None)).startswith("ScaledClock(inf")


def test_current_clock_reports_the_installed_clock_and_its_rate() -> None:
    import math

    async def which() -> cpl.Clock:
        return cpl.current_clock()

    assert isinstance(cpl.run(which), cpl.SystemClock)
    mock = MockClock()
    assert cpl.run(which, clock=mock) is mock
    assert mock.rate == math.inf
    scaled = cpl.ScaledClock(5)
    assert cpl.run(which, clock=scaled) is scaled
    assert scaled.rate == 5.0
    assert MockClock(autojump=False).rate == 0.0
    with pytest.raises(RuntimeError):
        cpl.current_clock()
