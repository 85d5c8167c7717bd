"""The robot's know-how as async plans: atomic actions, pick and place, search / fetch /
deliver / transport, and the table-setting demo. Depends on :mod:`executive` and :mod:`cpl`
only, never on :mod:`projection` internals.

The plan levels of CRAM HEAD's ``fetch-and-deliver-plans.lisp``, one module each, with
CRAM's nested failure handling and retry counts:

=================  ==========================================  ============================
action             retries (HEAD)                              raises when exhausted
=================  ==========================================  ============================
navigating         30 collision-check samples                  navigation-goal-in-collision
turning-towards    1 (turn the base, look again)               looking-high-level-failure
searching          9 search locations                          object-nowhere-to-be-found
fetching           10 relocations, 1 regrasp, 60 pick checks   object-unfetchable
delivering         outer 2 targets, 5 relocations, 2 targets   object-undeliverable
accessing/sealing  10 relocations                              env.-manipulation-impossible
transporting       object-undeliverable -> drop at the sink    what search / fetch raise
=================  ==========================================  ============================

:mod:`plans.navigation` (navigating, turning-towards, back-off), :mod:`plans.search`,
:mod:`plans.fetch`, :mod:`plans.deliver` (also the drop at the sink),
:mod:`plans.environment_access` (accessing/sealing; the drawer motions are in
:mod:`plans.environment`) and :mod:`plans.transport`; their rules' designator helpers are
in :mod:`plans._designators`.

Every level has one retry scope: the counter and the designator cursor it advances are
named there; inner counters are created inside the outer body, so they start afresh on
every outer retry (CRAM's lexical counters). Counters are :class:`CountedRetries` whose
names ("relocations", "regrasps", "targets", "search", ...) the demo tallies. Each budget
has one name, in the module of its plan (``plans.fetch.FETCH_RELOCATIONS``,
``plans.deliver.DELIVER_TARGETS``, ``plans.checks.PICK_CHECKS``, ...); the tables here and
in the modules are tested against them.
"""

# importing the plan modules registers their rules (one per action type, so order is free)
from . import (
    atomic,
    deliver,
    environment,
    environment_access,
    fetch,
    navigation,
    pick_place,
    pushing,
    search,
    transport,
)
from ._common import CountedRetries, retry_ledger
from ._imagination import ImaginedRun, imagine
from .checks import (
    PlacingPoseUnstable,
    check_environment_manipulation_collisions,
    check_navigating_collisions,
    check_picking_up_collisions,
    check_placing_collisions,
    check_placing_pose_stability,
)
from .demo import ObjectOutcome, table_setting
from .imagining import Imagined, imagine_best
from .reasoning import (
    ProjectedParameters,
    pick_best_parameters_by_distance,
    with_projected_task_tree,
)

__all__ = [
    "CountedRetries",
    "Imagined",
    "ImaginedRun",
    "ObjectOutcome",
    "PlacingPoseUnstable",
    "ProjectedParameters",
    "atomic",
    "check_environment_manipulation_collisions",
    "check_navigating_collisions",
    "check_picking_up_collisions",
    "check_placing_collisions",
    "check_placing_pose_stability",
    "deliver",
    "environment",
    "environment_access",
    "fetch",
    "imagine",
    "imagine_best",
    "navigation",
    "pick_best_parameters_by_distance",
    "pick_place",
    "pushing",
    "retry_ledger",
    "search",
    "table_setting",
    "transport",
    "with_projected_task_tree",
]
