""":class:`Store`: the experience store's Python API (the CLI's questions call it)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import Engine, and_, case, func, select
from sqlalchemy.engine import URL
from sqlalchemy.exc import DBAPIError
from sqlalchemy.sql import ColumnElement

from ._engine import _first_line, open_engine, shown, store_url
from ._errors import StoreError
from ._schema import nodes, parameters, retries, run_objects, runs
from ._writer import Rows, write_runs

__all__ = ["FAILURE_GROUPS", "Comparison", "ParameterStats", "Selection", "Store"]

#: What :meth:`Store.failures_by` can group by, and the column each one reads.
FAILURE_GROUPS = ("kind", "object", "step", "robot")


@dataclass(frozen=True)
class ParameterStats:
    """One choice of arm and grasp for an action on an object (and surface): how often it
    was used, how often the action succeeded, and where the base stood relative to the
    object in the successes (mean x, y in the base frame: the object ahead/left of it)."""

    arm: str | None
    grasp: str | None
    tried: int
    succeeded: int
    mean_rel_x: float | None
    mean_rel_y: float | None

    @property
    def rate(self) -> float:
        return self.succeeded / self.tried if self.tried else 0.0


@dataclass(frozen=True)
class Selection:
    """A campaign or a commit's runs, summarised for :meth:`Store.compare`."""

    label: str
    runs: int
    objects: int
    delivered: int
    failures: int  # where they arose, real runs only
    retries: int
    by_kind: dict[str, int] = field(default_factory=dict)

    @property
    def delivered_rate(self) -> float:
        return self.delivered / self.objects if self.objects else 0.0

    @property
    def failures_per_run(self) -> float:
        return self.failures / self.runs if self.runs else 0.0

    @property
    def retries_per_object(self) -> float:
        return self.retries / self.objects if self.objects else 0.0


@dataclass(frozen=True)
class Comparison:
    before: Selection
    after: Selection


class Store:
    """The experience store at ``url`` (a SQLAlchemy URL, or a path to an SQLite file).

    ``create=False`` (the questions): the store must exist (:class:`StoreMissingError`),
    nothing is written. ``create=True`` (the writers): the file or tables are made and
    migrated. Either way the checks run here, before anything else: a newer schema, a
    locked or corrupt file, a server that does not answer raise a :class:`StoreError`
    subclass naming what to fix. Use it as a context manager, or :meth:`close` it."""

    def __init__(self, url: str | os.PathLike[str] | URL, *, create: bool = False) -> None:
        self.url: URL = store_url(url)
        self.engine: Engine = open_engine(self.url, create=create)

    def __repr__(self) -> str:
        return f"Store({shown(self.url)!r})"

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.engine.dispose()

    # ------------------------------------------------------------------ writing
    def record(self, batches: Rows | Iterable[Rows]) -> float:
        """Write one run's rows (or several runs'); the seconds it took."""
        if isinstance(batches, dict):
            batches = [batches]
        return write_runs(self.engine, batches)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ reading
    def _all(self, query: Any) -> Sequence[Any]:
        try:
            with self.engine.connect() as conn:
                return conn.execute(query).all()
        except DBAPIError as exc:
            raise StoreError(f"cannot read {shown(self.url)}: {_first_line(exc)}") from None

    def run_count(self) -> int:
        return int(self._all(select(func.count()).select_from(runs))[0][0])

    def failures_by(
        self, by: str = "kind", *, imagined: bool = False, fault_rate: float | None = None
    ) -> list[tuple[str, int]]:
        """Failures counted where they arose (not once per ancestor they passed through),
        grouped ``by`` kind (failure class), object, step (the action performed) or robot,
        most first; real runs, or the imagined runs with ``imagined=True``."""
        if by not in FAILURE_GROUPS:
            raise StoreError(f"--by {by!r}: group failures by one of {', '.join(FAILURE_GROUPS)}")
        column: Any = {
            "kind": nodes.c.failure_class,
            "object": nodes.c.object,
            "step": nodes.c.step,
            "robot": runs.c.robot,
        }[by]
        where = and_(nodes.c.origin.is_(True), nodes.c.imagined.is_(imagined))
        query = select(column, func.count()).select_from(nodes)
        if by == "robot" or fault_rate is not None:
            query = query.join(runs, runs.c.id == nodes.c.run_id)
        if fault_rate is not None:
            where = and_(where, runs.c.fault_rate == fault_rate)
        query = query.where(where).group_by(column).order_by(func.count().desc(), column)
        return [(str(k) if k is not None else "-", int(n)) for k, n in self._all(query)]

    def failures_by_fault_rate(self, *, imagined: bool = False) -> dict[float, dict[str, int]]:
        """Failure kinds per fault rate (real runs at a uniform rate): for the plot."""
        query = (
            select(runs.c.fault_rate, nodes.c.failure_class, func.count())
            .select_from(nodes)
            .join(runs, runs.c.id == nodes.c.run_id)
            .where(
                nodes.c.origin.is_(True),
                nodes.c.imagined.is_(imagined),
                runs.c.fault_rate.is_not(None),
            )
            .group_by(runs.c.fault_rate, nodes.c.failure_class)
        )
        out: dict[float, dict[str, int]] = {}
        for rate, kind, n in self._all(query):
            out.setdefault(float(rate), {})[str(kind)] = int(n)
        return out

    def runs_per_fault_rate(self) -> dict[float, int]:
        query = (
            select(runs.c.fault_rate, func.count())
            .where(runs.c.fault_rate.is_not(None))
            .group_by(runs.c.fault_rate)
        )
        return {float(r): int(n) for r, n in self._all(query)}

    def retries(self) -> list[tuple[str, int, int, int]]:
        """Per recovery (the retry scope's kind): retries spent in all, the objects that
        spent any, and of those the objects delivered in the end; most spent first."""
        delivered = case((run_objects.c.delivered.is_(True), 1), else_=0)
        query = (
            select(
                retries.c.recovery,
                func.sum(retries.c.count),
                func.count(),
                func.sum(delivered),
            )
            .select_from(retries)
            .join(
                run_objects,
                and_(
                    run_objects.c.run_id == retries.c.run_id,
                    run_objects.c.object == retries.c.object,
                ),
            )
            .group_by(retries.c.recovery)
            .order_by(func.sum(retries.c.count).desc(), retries.c.recovery)
        )
        return [(str(k), int(s), int(n), int(d or 0)) for k, s, n, d in self._all(query)]

    def surfaces(self, obj: str | None = None) -> list[str]:
        query = select(parameters.c.surface).distinct()
        if obj is not None:
            query = query.where(parameters.c.object == obj)
        return sorted(str(s) for (s,) in self._all(query) if s is not None)

    def parameters(
        self,
        obj: str,
        *,
        surface: str | None = None,
        action: str = "picking-up",
        imagined: bool | None = False,
    ) -> list[ParameterStats]:
        """Which arm and grasp the ``action`` on ``obj`` (on ``surface``) used, how often it
        succeeded, and the mean base-relative object position of the successes; best
        rate first. ``imagined``: real runs (False), imagined (True), both (None)."""
        ok = case((parameters.c.status == "SUCCEEDED", 1), else_=0)
        rel_x = case((parameters.c.status == "SUCCEEDED", parameters.c.rel_x), else_=None)
        rel_y = case((parameters.c.status == "SUCCEEDED", parameters.c.rel_y), else_=None)
        conditions: list[ColumnElement[bool]] = [
            parameters.c.object == obj,
            parameters.c.action == action,
        ]
        if surface is not None:
            conditions.append(parameters.c.surface == surface)
        if imagined is not None:
            conditions.append(parameters.c.imagined.is_(imagined))
        query = (
            select(
                parameters.c.arm,
                parameters.c.grasp,
                func.count(),
                func.sum(ok),
                func.avg(rel_x),
                func.avg(rel_y),
            )
            .where(*conditions)
            .group_by(parameters.c.arm, parameters.c.grasp)
        )
        stats = [
            ParameterStats(
                arm,
                grasp,
                int(n),
                int(s or 0),
                None if x is None else float(x),
                None if y is None else float(y),
            )
            for arm, grasp, n, s, x, y in self._all(query)
        ]
        return sorted(stats, key=lambda p: (-p.rate, -p.tried, str(p.arm), str(p.grasp)))

    def labels(self) -> list[tuple[str, str, int]]:
        """``(kind, label, runs)``: every campaign and commit in the store."""
        out = []
        for kind, column in (("campaign", runs.c.campaign), ("commit", runs.c.commit)):
            query = select(column, func.count()).where(column.is_not(None)).group_by(column)
            out += [(kind, str(v), int(n)) for v, n in self._all(query)]
        return out

    def _runs_of(self, label: str) -> ColumnElement[bool]:
        """The runs of a campaign id or a commit (either in full or a unique prefix)."""
        labels = self.labels()
        found = [(kind, value) for kind, value, _ in labels if value == label.strip()]
        if not found:  # no exact match: a unique prefix
            found = [(kind, value) for kind, value, _ in labels if value.startswith(label.strip())]
        if not label.strip() or not found:
            known = (
                ", ".join(f"{v if k == 'campaign' else v[:12]} ({k})" for k, v, _ in labels[:8])
                or "none"
            )
            raise StoreError(
                f"{label!r} names no campaign or commit in {shown(self.url)} (known: {known})"
            )
        if len(found) > 1:
            raise StoreError(
                f"{label!r} matches {len(found)} campaigns/commits "
                f"({', '.join(v[:12] for _, v in found[:5])}); give more of it"
            )
        kind, value = found[0]
        return (runs.c.campaign if kind == "campaign" else runs.c.commit) == value

    def select_runs(self, label: str) -> Selection:
        which = self._runs_of(label)
        ((n, objects, delivered),) = self._all(
            select(func.count(), func.sum(runs.c.objects), func.sum(runs.c.delivered)).where(which)
        )
        kinds = self._all(
            select(nodes.c.failure_class, func.count())
            .select_from(nodes)
            .join(runs, runs.c.id == nodes.c.run_id)
            .where(which, nodes.c.origin.is_(True), nodes.c.imagined.is_(False))
            .group_by(nodes.c.failure_class)
        )
        (spent,) = self._all(
            select(func.coalesce(func.sum(retries.c.count), 0))
            .select_from(retries)
            .join(runs, runs.c.id == retries.c.run_id)
            .where(which)
        )[0]
        by_kind = {str(k): int(c) for k, c in kinds}
        return Selection(
            label,
            int(n),
            int(objects or 0),
            int(delivered or 0),
            sum(by_kind.values()),
            int(spent),
            dict(sorted(by_kind.items(), key=lambda kv: (-kv[1], kv[0]))),
        )

    def compare(self, before: str, after: str) -> Comparison:
        """Two campaigns or two commits (ids or unique prefixes) side by side."""
        return Comparison(self.select_runs(before), self.select_runs(after))
