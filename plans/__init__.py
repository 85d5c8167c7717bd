"""The robot's know-how as async plans: atomic actions, pick and place, search / fetch /
deliver / transport, and the table-setting demo. Depends on :mod:`executive` and :mod:`cpl`
only, never on :mod:`projection` internals."""

from . import atomic, environment, fetch_deliver, pick_place
from ._common import CountedRetries, retry_ledger
from .checks import (
    PlacingPoseUnstable,
    check_environment_manipulation_collisions,
    check_navigating_collisions,
    check_picking_up_collisions,
    check_placing_collisions,
    check_placing_pose_stability,
)
from .demo import ObjectOutcome, spawn_scene, table_setting
from .imagining import Imagined, imagine_best
from .reasoning import (
    ProjectedParameters,
    pick_best_parameters_by_distance,
    with_projected_task_tree,
)

__all__ = [
    "CountedRetries",
    "Imagined",
    "ObjectOutcome",
    "PlacingPoseUnstable",
    "ProjectedParameters",
    "atomic",
    "check_environment_manipulation_collisions",
    "check_navigating_collisions",
    "check_picking_up_collisions",
    "check_placing_collisions",
    "check_placing_pose_stability",
    "environment",
    "fetch_deliver",
    "imagine_best",
    "pick_best_parameters_by_distance",
    "pick_place",
    "retry_ledger",
    "spawn_scene",
    "table_setting",
    "with_projected_task_tree",
]
