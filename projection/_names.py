"""Errors for unknown names whose "did you mean" hint is built only when the message is
read.

Lookups on the hot path (a costmap asking for a joint, a probe asking for a link) may
fail on purpose and catch the error; such an error must not pay for its message. The
:func:`difflib.get_close_matches` hint costs ~1 ms over the world's ~250 names, so
:class:`UnknownName` keeps the name and the known names and renders the hint in
``__str__`` (once, then cached). Ask the world first (``World.has_joint``) where a miss is
expected; this keeps the miss cheap where it is not.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable

__all__ = ["UnknownName"]


class UnknownName(LookupError):
    """``LookupError`` for an unknown ``name`` of some ``what`` (``"link"``, ``"joint"``),
    with close matches among ``known`` computed lazily when the message is rendered.

    ``known`` is an iterable or a zero-argument callable returning one (so that not even
    the list of names is built unless the message is read)."""

    def __init__(
        self,
        what: str,
        name: object,
        known: Iterable[str] | Callable[[], Iterable[str]] = (),
        *,
        style: str = "did-you-mean",
        n: int = 5,
    ) -> None:
        super().__init__(what, name)
        self.what = what
        self.name = name
        self._known = known
        self._style = style
        self._n = n
        self._message: str | None = None

    @property
    def close_matches(self) -> list[str]:
        """The known names close to :attr:`name` (computed on first use)."""
        known = self._known() if callable(self._known) else self._known
        return difflib.get_close_matches(str(self.name), list(known), n=self._n, cutoff=0.5)

    def __reduce__(self) -> tuple[object, ...]:
        # pickles (e.g. across a campaign's process pool) with its matches, not its world
        return (_rebuild, (self.what, self.name, tuple(self.close_matches), self._style))

    def __str__(self) -> str:
        if self._message is None:
            close = self.close_matches
            head = f"unknown {self.what} {self.name!r}"
            if self._style == "did-you-mean":
                self._message = head + (f"; did you mean {', '.join(close)}?" if close else "")
            else:
                self._message = f"{head}; close matches: {', '.join(close) or 'none'}"
        return self._message


def _rebuild(what: str, name: object, known: tuple[str, ...], style: str) -> UnknownName:
    return UnknownName(what, name, known, style=style)
