"""The experience store (issue 29): every real and imagined run in a database, and the
questions a robot team asks after a thousand runs answered from it.

SQLite by default (``OUT/experience.sqlite`` next to the demo's and the campaign's
outputs), PostgreSQL by URL (``postgresql+psycopg://user@host/db``), one schema
(:mod:`._schema`, versioned by :mod:`._migrations`). The demo and every campaign run
write it after the run (:func:`record_run`, :func:`run_rows`); :class:`Store` answers
the questions (``aiocram experience ...``)::

    with Store("out/campaign/experience.sqlite") as store:
        store.failures_by("kind")          # [("NavigationGoalInCollision", 12), ...]

Deliberate difference from CRAM: CRAM logs episodes as NEEMs into KnowRob's MongoDB and
leaves the questions to Prolog queries written per study; here the store is relational,
its questions are built in, and real and imagined runs share one table of task-tree nodes,
told apart by the ``imagined`` flag.
"""

from ._engine import STORE_FILE, store_url
from ._errors import (
    StoreCorruptError,
    StoreError,
    StoreLockedError,
    StoreMissingError,
    StoreUnreachableError,
    StoreVersionError,
)
from ._extract import current_commit, robot_name, run_rows
from ._plot import plot_failures
from ._priors import (
    PRIORS_VERSION,
    LearnedPriors,
    PriorsCorruptError,
    PriorsError,
    PriorsRobotError,
    PriorsVersionError,
    learn_priors,
)
from ._record import check_store, default_store, record_run
from ._schema import SCHEMA_VERSION
from ._store import FAILURE_GROUPS, Comparison, ParameterStats, Selection, Store

__all__ = [
    "FAILURE_GROUPS",
    "PRIORS_VERSION",
    "SCHEMA_VERSION",
    "STORE_FILE",
    "Comparison",
    "LearnedPriors",
    "ParameterStats",
    "PriorsCorruptError",
    "PriorsError",
    "PriorsRobotError",
    "PriorsVersionError",
    "Selection",
    "Store",
    "StoreCorruptError",
    "StoreError",
    "StoreLockedError",
    "StoreMissingError",
    "StoreUnreachableError",
    "StoreVersionError",
    "check_store",
    "current_commit",
    "default_store",
    "learn_priors",
    "plot_failures",
    "record_run",
    "robot_name",
    "run_rows",
    "store_url",
]
