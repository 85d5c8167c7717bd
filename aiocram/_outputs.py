"""An output directory written all at once: files go to a hidden staging directory inside
it and are renamed into place by :meth:`Outputs.commit`.

So a run that fails early, is interrupted or aborted never leaves the previous run's
files half overwritten: until :meth:`commit` the directory holds the previous run's
output untouched; after it, this run's files (and none of the previous run's files of
the same kinds, see ``stale``).
"""

from __future__ import annotations

import errno
import os
import shutil
from collections.abc import Iterable
from pathlib import Path

__all__ = ["OutputError", "Outputs", "check_out_dir", "out_dir_arg"]


def out_dir_arg(text: str) -> Path:
    """The argparse type of an output-directory flag: the path, or a usage error for an
    empty one (``--out ""`` would otherwise write into the current directory)."""
    import argparse

    if not text.strip():
        raise argparse.ArgumentTypeError(
            f"needs a directory name, got {text!r} (give '.' for the current directory "
            "if that is really meant)"
        )
    return Path(text)


class OutputError(ValueError):
    """The output directory cannot be used (the message says why and names the flag)."""


def check_out_dir(out: Path, flag: str = "--out") -> None:
    """Raise :class:`OutputError` unless ``out`` is, or can be made, a writable directory.

    Nothing is created: the check walks up to the nearest existing ancestor and asks the
    file system whether a directory could be made there."""
    if out.exists() and not out.is_dir():
        raise OutputError(f"{flag} {out}: exists and is not a directory; give a directory")
    probe = out
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise OutputError(f"{flag} {out}: {probe} is a file, so no directory can be made in it")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{flag} {out}: {probe} is not writable; give a directory you can write")


class Outputs:
    """Files of one run in ``out`` (see the module docstring).

    ``stale``: glob patterns of the previous run's files that :meth:`commit` removes when
    this run did not write a file of that name (e.g. ``costmap-*.png``: a run that drew
    fewer costmaps must not leave the older ones beside its own)."""

    def __init__(self, out: Path, stale: Iterable[str] = ()) -> None:
        self.out = out
        self.stale = tuple(stale)
        try:
            out.mkdir(parents=True, exist_ok=True)
            self.staging = Path(
                os.path.realpath(out / f".partial-{os.getpid()}")
            )  # invariant: inside out, so renames never cross file systems
            if self.staging.exists():
                shutil.rmtree(self.staging)
            self.staging.mkdir()
        except OSError as exc:
            raise OutputError(f"--out {out}: cannot write there: {exc.strerror or exc}") from None
        self.committed: list[Path] = []

    def path(self, name: str) -> Path:
        """Where to write the file ``name`` during the run."""
        return self.staging / name

    def commit(self, order: Iterable[str] = ()) -> list[Path]:
        """Move every staged file into ``out`` (replacing files of the same name), remove
        the previous run's ``stale`` files, drop the staging directory; returns the final
        paths, those named in ``order`` first. Idempotent; safe to call from a signal
        handler (plain renames)."""
        if not self.staging.exists():
            return self.committed
        names = sorted(p.name for p in self.staging.iterdir())
        first = [n for n in order if n in names]
        names = first + [n for n in names if n not in first]
        for pattern in self.stale:
            for old in self.out.glob(pattern):
                if old.name not in names and old.is_file():
                    old.unlink()
        for name in names:
            target = self.out / name
            try:
                os.replace(self.staging / name, target)
            except OSError as exc:  # pragma: no cover - e.g. a directory of that name
                if exc.errno not in (errno.EISDIR, errno.ENOTEMPTY):
                    raise
                continue
            self.committed.append(target)
        shutil.rmtree(self.staging, ignore_errors=True)
        return self.committed
