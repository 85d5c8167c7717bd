"""The experience store's tables (SQLAlchemy Core), schema version :data:`SCHEMA_VERSION`.

One row per run (real runs; the imagined runs of projection reasoning live inside a real
run's tree, flagged ``imagined``), its objects as the true world measured them, the
retries each recovery spent, every task of its tree (real and imagined), and the
parameters that designator resolution chose for each pick and place with the outcome of
the action that used them. Keys are UUID strings, so stores merge without renumbering.

``docs/experience.md`` documents every column.
"""

from __future__ import annotations

from sqlalchemy import (
    Boolean,
    Column,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Table,
    Text,
)

__all__ = [
    "MIGRATIONS_TABLE",
    "SCHEMA_VERSION",
    "metadata",
    "nodes",
    "parameters",
    "retries",
    "run_objects",
    "runs",
]

#: The schema version this aiocram writes and reads; a store with a higher one is refused.
SCHEMA_VERSION = 1

metadata = MetaData()

#: ``version`` (one row per applied migration), ``description``, ``applied_at`` (UTC ISO).
MIGRATIONS_TABLE = Table(
    "experience_schema",
    metadata,
    Column("version", Integer, primary_key=True, autoincrement=False),
    Column("description", Text, nullable=False),
    Column("applied_at", String(32), nullable=False),
)

runs = Table(
    "runs",
    metadata,
    Column("id", String(36), primary_key=True),  # uuid4
    Column("campaign", String(64), index=True),  # None: a demo run
    Column("source", String(16), nullable=False),  # "demo" | "campaign"
    Column("robot", String(64), nullable=False),
    Column("seed", Integer, nullable=False),
    Column("fault_rate", Float),  # the uniform rate, None for a per-kind profile
    Column("faults", Text),  # the fault profile as given
    Column("commit", String(40), index=True),  # git rev of the code, None if unknown
    Column("projection", Boolean, nullable=False),
    Column("objects", Integer, nullable=False),  # planned
    Column("delivered", Integer, nullable=False),  # measured on the true world
    Column("claimed", Integer, nullable=False),  # reported placed by the plan
    Column("sim_time_s", Float),
    Column("wall_time_s", Float),
    Column("error", Text),  # the harness crashed in this run (no tree then)
    Column("recorded_at", String(32), nullable=False),
)

run_objects = Table(
    "run_objects",
    metadata,
    Column("run_id", String(36), ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    Column("object", String(64), primary_key=True),  # the object's type
    Column("name", String(64)),
    Column("delivered", Boolean, nullable=False),
    Column("claimed", Boolean, nullable=False),
    Column("phantom", Boolean, nullable=False),
    Column("place", String(64)),  # where the true world has it (island, floor, ...)
    Column("toppled", Boolean, nullable=False),
    Column("failure", String(128)),  # the plan's failure class, None when it claimed
    Column("retries", Integer, nullable=False),
)

retries = Table(
    "retries",
    metadata,
    Column("run_id", String(36), ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    Column("object", String(64), primary_key=True),
    Column("recovery", String(64), primary_key=True),  # the retry scope's kind
    Column("count", Integer, nullable=False),
)

nodes = Table(
    "nodes",
    metadata,
    Column("run_id", String(36), ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    Column("idx", Integer, primary_key=True, autoincrement=False),  # pre-order
    Column("parent_idx", Integer),
    Column("imagined", Boolean, nullable=False),  # inside an imagined (projection) run
    Column("name", String(128), nullable=False),
    Column("kind", String(32), nullable=False),
    Column("action", String(64)),  # the action type this task performed, if any
    Column("step", String(64)),  # the nearest performed action at or above it
    Column("object", String(64)),  # the object type of the nearest action naming one
    Column("status", String(16), nullable=False),
    Column("start_time", Float),
    Column("end_time", Float),
    Column("failure_class", String(128)),
    Column("failure_message", Text),
    # where the failure arose: no child failed with the same failure object (a failure
    # counted once, not once per ancestor it passed through)
    Column("origin", Boolean, nullable=False),
)
# the failure questions read this index only, not the table (covering: kind, object, step,
# run): well under 1 s at millions of nodes (BENCHMARKS.md)
Index(
    "nodes_failures",
    nodes.c.origin,
    nodes.c.imagined,
    nodes.c.failure_class,
    nodes.c.object,
    nodes.c.step,
    nodes.c.run_id,
)

parameters = Table(
    "parameters",
    metadata,
    Column("run_id", String(36), ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    Column("node_idx", Integer, primary_key=True, autoincrement=False),
    Column("imagined", Boolean, nullable=False),
    Column("action", String(32), nullable=False),  # "picking-up" | "placing"
    Column("object", String(64)),
    Column("surface", String(64)),  # the supporting surface picked from / placed on
    Column("arm", String(16)),
    Column("grasp", String(32)),
    # the base pose (map) the navigating step before the action stood the robot at
    Column("base_x", Float),
    Column("base_y", Float),
    Column("base_yaw", Float),
    # the object (picking-up) or the placing pose (placing) in the base's frame: the base
    # pose relative to the object, as the action's own poses give it
    Column("rel_x", Float),
    Column("rel_y", Float),
    Column("rel_z", Float),
    Column("rel_yaw", Float),
    Column("status", String(16), nullable=False),  # of the action that used them
    Column("failure_class", String(128)),
)
Index("parameters_lookup", parameters.c.object, parameters.c.surface, parameters.c.action)
