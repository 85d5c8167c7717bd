"""The demo's files: where the plans' logs go during a run (``plans.log``), and the
pictures drawn after it (final scene, robot view, costmaps, the floor plan's recorders
are in :mod:`aiocram._floorplan`)."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["OUTPUT_FILES", "STALE", "route_plan_logs", "write_pictures"]

#: Files of a demo run in ``--out``, in the order the summary lists them; ``costmap-*``
#: come after. Older runs' files of these kinds are replaced when the run ends.
OUTPUT_FILES = ("log.jsonl", "plans.log", "final_scene.png", "robot_view.png")
STALE = (*OUTPUT_FILES, "costmap-*.png", "floor_plan.png")


def route_plan_logs(path: Path | None) -> Callable[[], None]:
    """Plans log every retry (``plans.retries``: each one a ``CountedRetries`` grants or
    refuses, INFO) and every failure a retry scope handles (WARNING), and the truth's
    knock watcher every knocked object (``aiocram.knocks``, WARNING); during the demo
    these go to ``path`` (``OUT/plans.log``; nowhere without ``--out``) at INFO, so that
    the console shows the live view and the summary. Returns the function that undoes
    this."""
    import logging

    handler: logging.Handler
    if path is not None:
        handler = logging.FileHandler(path, mode="w", encoding="utf-8")
        handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    else:
        handler = logging.NullHandler()
    loggers = [
        logging.getLogger(name)
        for name in ("plans", "executive", "projection", "cpl", "aiocram.knocks")
    ]
    saved = [(lg, lg.propagate, lg.level) for lg in loggers]
    for lg in loggers:
        lg.propagate = False
        lg.setLevel(logging.INFO)
        lg.addHandler(handler)

    def undo() -> None:
        for lg, propagate, level in saved:
            lg.removeHandler(handler)
            lg.propagate = propagate
            lg.setLevel(level)
        handler.close()

    return undo


def write_pictures(
    outputs: Any,
    true_world: Any,
    camera: Any,
    costmaps: Any,
    engine_box: list[Any],
    interrupts: Any = None,
) -> None:
    """The final scene (true world), the head camera at the last detection, and the
    costmaps the real run navigated by (see :mod:`aiocram._figures`). A picture that
    cannot be drawn is reported on stderr: a picture never fails the demo."""
    from aiocram._figures import write_scene
    from projection import render

    engine = engine_box[0] if engine_box else None
    # every other costmap figure is drawn by a forked copy of this process meanwhile (the
    # same pictures in about half the wall time on two cores)
    child = None
    if engine is not None and len(costmaps.uses) > 1:
        adopt = interrupts.adopt if interrupts is not None else None
        child = _fork(lambda: costmaps.figures(engine, outputs.staging, part=(1, 2)), adopt)
    try:
        try:
            # from where every object shows (the fixed overview hid some behind others)
            shot = render.camera_showing(true_world)
            caption = "the true world at the end of the run"
            write_scene(true_world, outputs.path("final_scene.png"), shot, caption)
            camera.write(outputs.path("robot_view.png"))
        except Exception as exc:  # reported; the run's outcome stands
            print(f"(pictures not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
        if engine is not None:
            costmaps.figures(engine, outputs.staging, part=(0, 1) if child is None else (0, 2))
    finally:
        if child is not None:
            _, status = os.waitpid(child, 0)
            if interrupts is not None:
                interrupts.release(child)
            if status != 0:
                print(
                    f"(some costmap pictures not drawn: their process ended with {status})",
                    file=sys.stderr,
                )


def _fork(work: Callable[[], Any], adopt: Callable[[int], None] | None = None) -> int | None:
    """Run ``work`` in a forked child that ends with ``os._exit`` (none of this process's
    cleanup runs there) and ignores Ctrl-C (the parent waits for it); the child's pid, or
    None where there is no fork or other threads run (``work`` is then left to the
    caller). ``adopt(pid)`` is called in the parent before a Ctrl-C can be handled (SIGINT
    is blocked around the fork), so an abort by a second Ctrl-C can kill the child
    (:meth:`aiocram._interrupt.Interrupts.adopt`) rather than leave it writing after the
    command ended."""
    import logging
    import signal
    import threading

    if not hasattr(os, "fork") or threading.active_count() > 1:
        return None  # a forked child would hold only this thread (--gui has others)
    # nothing buffered is inherited (the child could write it a second time)
    sys.stdout.flush()
    sys.stderr.flush()
    for name in ("plans", "executive", "projection", "cpl"):
        for handler in logging.getLogger(name).handlers:
            handler.flush()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        pid = os.fork()
    except OSError:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        return None
    if pid:
        try:
            if adopt is not None:
                adopt(pid)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a pending Ctrl-C runs now
        return pid
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        work()
        code = 0
    except BaseException:
        import traceback

        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
