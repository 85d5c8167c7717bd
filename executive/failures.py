"""CRAM's common failure hierarchy, under :class:`cpl.PlanFailure`.

Low-level failures are raised by process modules (the body of the robot); high-level
failures are raised by plans. The tree follows CRAM's ``cram_common_failures`` at the
HEAD we take as reference. CRAM's oddities that plans depend on are kept on purpose:

- :class:`TorsoLowLevelFailure` and :class:`GripperLowLevelFailure` are *manipulation*
  failures, so a handler for :class:`ManipulationLowLevelFailure` also sees a torso or
  gripper failure (``fetch`` relies on this when it relocates).
- :class:`DesignatorError` is *not* a plan failure (CRAM's ``designator-error`` is a
  ``simple-error``): a designator that cannot be resolved is bad input, and plans translate
  it explicitly into the high-level failure that fits. :class:`DesignatorReferenceFailure`
  is both, as CRAM's ``designator-reference-failure``.

Every class carries ``cram_name``, CRAM's spelling, so the task tree and logs read like CRAM.
"""

from __future__ import annotations

from typing import Any

from cpl import PlanFailure

__all__ = [
    "ActionlibActionTimedOut",
    "DeliveringFailed",
    "DesignatorError",
    "DesignatorInputError",
    "DesignatorReferenceFailure",
    "EnvironmentManipulationGoalNotReached",
    "EnvironmentManipulationImpossible",
    "EnvironmentUnreachable",
    "FetchingFailed",
    "GripperClosedCompletely",
    "GripperGoalNotReached",
    "GripperLowLevelFailure",
    "HighLevelFailure",
    "LookingHighLevelFailure",
    "LowLevelFailure",
    "ManipulationGoalInCollision",
    "ManipulationGoalNotReached",
    "ManipulationLowLevelFailure",
    "ManipulationPoseUnreachable",
    "NavigationGoalInCollision",
    "NavigationGoalNotReached",
    "NavigationHighLevelFailure",
    "NavigationLowLevelFailure",
    "NavigationPoseUnreachable",
    "NoKitchenDescription",
    "NoProcessModule",
    "NoRobotDescription",
    "NoWorldModel",
    "ObjectNowhereToBeFound",
    "ObjectUndeliverable",
    "ObjectUnfetchable",
    "ObjectUnreachable",
    "PerceptionLowLevelFailure",
    "PerceptionObjectNotFound",
    "PerceptionObjectNotInWorld",
    "ProcessModuleGoalEvaporated",
    "PtuGoalNotReached",
    "PtuGoalUnreachable",
    "PtuLowLevelFailure",
    "ResourceConflict",
    "SearchingFailed",
    "TorsoGoalNotReached",
    "TorsoGoalUnreachable",
    "TorsoLowLevelFailure",
    "cram_name_of",
]


class _Described(PlanFailure):
    """A plan failure with a ``description`` (CRAM's ``simple-plan-failure`` family)."""

    cram_name = "simple-plan-failure"

    def __init__(self, description: str | None = None, **details: Any) -> None:
        super().__init__(description, **details)

    @property
    def description(self) -> str:
        return self.message


def _field(name: str) -> property:
    def get(self: PlanFailure) -> Any:
        return self.details.get(name)

    return property(get, doc=f"The failure's ``{name}`` field (``None`` when not given).")


# --------------------------------------------------------------------------- low level
class LowLevelFailure(_Described):
    """Thrown by process modules."""

    cram_name = "low-level-failure"
    default_message = "Low-level failure."


class ActionlibActionTimedOut(LowLevelFailure):
    cram_name = "actionlib-action-timed-out"
    default_message = "Action timed out."


class ManipulationLowLevelFailure(LowLevelFailure):
    cram_name = "manipulation-low-level-failure"
    default_message = "Manipulation failed."


class ManipulationGoalNotReached(ManipulationLowLevelFailure):
    cram_name = "manipulation-goal-not-reached"
    default_message = "Manipulation goal not reached."


class ManipulationPoseUnreachable(ManipulationLowLevelFailure):
    """No IK solution (or one that forward kinematics does not confirm)."""

    cram_name = "manipulation-pose-unreachable"
    default_message = "Manipulation pose unreachable."


class GripperLowLevelFailure(ManipulationLowLevelFailure):
    """Kept under manipulation failures as in CRAM's HEAD. Field: ``action``."""

    cram_name = "gripper-low-level-failure"
    default_message = "Gripper failed."
    action = _field("action")


class GripperClosedCompletely(GripperLowLevelFailure):
    """The gripper closed without anything between its fingers."""

    cram_name = "gripper-closed-completely"
    default_message = "Gripper closed completely: nothing gripped."


class GripperGoalNotReached(GripperLowLevelFailure):
    cram_name = "gripper-goal-not-reached"
    default_message = "Gripper goal not reached."


class TorsoLowLevelFailure(ManipulationLowLevelFailure):
    """A torso failure is a manipulation failure in CRAM; we keep it. Field: ``torso``."""

    cram_name = "torso-low-level-failure"
    default_message = "Torso failed."
    torso = _field("torso")


class TorsoGoalUnreachable(TorsoLowLevelFailure):
    cram_name = "torso-goal-unreachable"
    default_message = "Torso goal unreachable."


class TorsoGoalNotReached(TorsoLowLevelFailure):
    cram_name = "torso-goal-not-reached"
    default_message = "Torso goal not reached (outside the joint limits)."


class EnvironmentManipulationGoalNotReached(ManipulationLowLevelFailure):
    cram_name = "environment-manipulation-goal-not-reached"
    default_message = "Environment manipulation goal not reached."


class NavigationLowLevelFailure(LowLevelFailure):
    """Field: ``location`` (the goal pose or designator)."""

    cram_name = "navigation-low-level-failure"
    default_message = "Navigation failed."
    location = _field("location")


class NavigationPoseUnreachable(NavigationLowLevelFailure):
    """The base would collide at the goal (``drive`` restored the previous pose)."""

    cram_name = "navigation-pose-unreachable"
    default_message = "Navigation pose unreachable: the robot would be in collision."


class NavigationGoalNotReached(NavigationLowLevelFailure):
    cram_name = "navigation-goal-not-reached"
    default_message = "Navigation goal not reached."


class PerceptionLowLevelFailure(LowLevelFailure):
    cram_name = "perception-low-level-failure"
    default_message = "Perception failed."


class PerceptionObjectNotFound(PerceptionLowLevelFailure):
    """Nothing matching the object designator is visible. Field: ``object``."""

    cram_name = "perception-object-not-found"
    default_message = "Object not found."
    object = _field("object")


class PerceptionObjectNotInWorld(PerceptionLowLevelFailure):
    cram_name = "perception-object-not-in-world"
    default_message = "Object not in the world."
    object = _field("object")


class PtuLowLevelFailure(LowLevelFailure):
    """Pan-tilt unit failures. Field: ``target``."""

    cram_name = "ptu-low-level-failure"
    default_message = "Pan-tilt unit failed."
    target = _field("target")


class PtuGoalUnreachable(PtuLowLevelFailure):
    cram_name = "ptu-goal-unreachable"
    default_message = "Pan-tilt goal unreachable."


class PtuGoalNotReached(PtuLowLevelFailure):
    """Pan or tilt had to be clamped to the joint limits."""

    cram_name = "ptu-goal-not-reached"
    default_message = "Pan-tilt goal not reached (beyond the joint limits)."


# -------------------------------------------------------------------------- high level
class HighLevelFailure(_Described):
    """Thrown by plans."""

    cram_name = "high-level-failure"
    default_message = "High-level failure."


class NavigationHighLevelFailure(HighLevelFailure):
    cram_name = "navigation-high-level-failure"
    default_message = "Navigation failed."


class NavigationGoalInCollision(NavigationHighLevelFailure):
    """No collision-free base pose among the samples tried. Field: ``pose``."""

    cram_name = "navigation-goal-in-collision"
    default_message = "Navigation goal in collision."
    pose = _field("pose")


class LookingHighLevelFailure(HighLevelFailure):
    cram_name = "looking-high-level-failure"
    default_message = "Could not look at the target."


class ObjectUnreachable(HighLevelFailure):
    """No IK / collision-free arm configuration. Field: ``object``."""

    cram_name = "object-unreachable"
    default_message = "Object unreachable."
    object = _field("object")


class ManipulationGoalInCollision(HighLevelFailure):
    cram_name = "manipulation-goal-in-collision"
    default_message = "Manipulation goal in collision."


class ObjectUnfetchable(HighLevelFailure):
    cram_name = "object-unfetchable"
    default_message = "Object unfetchable."
    object = _field("object")


class ObjectUndeliverable(HighLevelFailure):
    cram_name = "object-undeliverable"
    default_message = "Object undeliverable."
    object = _field("object")


class ObjectNowhereToBeFound(HighLevelFailure):
    cram_name = "object-nowhere-to-be-found"
    default_message = "Object nowhere to be found."
    object = _field("object")


class EnvironmentUnreachable(HighLevelFailure):
    cram_name = "environment-unreachable"
    default_message = "Environment unreachable."


class EnvironmentManipulationImpossible(HighLevelFailure):
    cram_name = "environment-manipulation-impossible"
    default_message = "Environment manipulation impossible."


class SearchingFailed(HighLevelFailure):
    cram_name = "searching-failed"
    default_message = "Searching failed."
    object = _field("object")


class FetchingFailed(HighLevelFailure):
    cram_name = "fetching-failed"
    default_message = "Fetching failed."
    object = _field("object")


class DeliveringFailed(HighLevelFailure):
    cram_name = "delivering-failed"
    default_message = "Delivering failed."
    object = _field("object")


# ------------------------------------------------------------------- designators, dispatch
class DesignatorError(Exception):
    """A designator cannot be resolved: unknown type, missing or invalid property, no
    solution. Not a plan failure (as in CRAM); the message names the designator and what
    to fix. Field: ``designator``."""

    cram_name = "designator-error"

    def __init__(self, message: str, designator: Any = None) -> None:
        super().__init__(message)
        self.message = message
        self.designator = designator


class DesignatorInputError(DesignatorError):
    """A designator is malformed: an unknown type, key, name or arm, or a value of the
    wrong kind. The programmer must fix the designator; no other solution, place or retry
    can. So plans never translate it into a high-level failure (``searching`` does not turn
    it into ``object-nowhere-to-be-found``) and retry scopes never retry it: it surfaces
    as itself, with its "did you mean ..." hint.

    Deliberate difference from CRAM: CRAM's plans translated every ``designator-error``
    (a misspelt surface became "object nowhere to be found"); we translate only the
    errors a retry or another solution could cure (e.g. an empty costmap)."""

    cram_name = "designator-error"


class DesignatorReferenceFailure(PlanFailure, DesignatorError):
    """Both a plan failure and a designator error (CRAM's
    ``designator-reference-failure``), for plans that want resolution trouble handled like
    any other failure."""

    cram_name = "designator-reference-failure"

    def __init__(self, message: str, designator: Any = None) -> None:
        PlanFailure.__init__(self, message, designator=designator)
        self.designator = designator


class NoProcessModule(PlanFailure):
    """``perform`` found no running process module that accepts a motion. Field:
    ``motion``."""

    cram_name = "no-process-module"
    default_message = "No running process module accepts this motion."
    motion = _field("motion")


class ProcessModuleGoalEvaporated(PlanFailure):
    """A process-module goal was evaporated while its caller went on (someone evaporated
    the goal's task, or the ``with_process_modules`` block that ran the module was left).
    Not in CRAM, where the caller would just see the motion end; we make it a plan failure so
    the plan does not mistake a stopped motion for a finished one. Fields: ``motion``,
    ``module``."""

    cram_name = "process-module-goal-evaporated"
    default_message = "The process-module goal was evaporated before it finished."
    motion = _field("motion")
    module = _field("module")


class ResourceConflict(PlanFailure):
    """A goal needs a part of the robot (an arm, the base...) that a concurrent action
    outside its own subtree holds (see :mod:`executive._resources`). Raised before the
    goal's plan starts or its motion reaches a process module, so nothing moved for it;
    the message says what to do (perform them one after the other, or use a free part).
    Not in CRAM, whose process modules queue a second goal silently. Neither a low-level
    nor a high-level failure: handlers that ignore or retry those do not swallow it.
    Fields: ``resource``, ``goal`` and ``task`` (the goal that failed and the task that
    performed it), ``holder`` and ``holder_task`` (the goal that holds the resource)."""

    cram_name = "resource-conflict"
    default_message = "A resource the goal needs is held by a concurrent action."
    resource = _field("resource")
    goal = _field("goal")
    task = _field("task")
    holder = _field("holder")
    holder_task = _field("holder_task")


class NoWorldModel(LookupError):
    """The current environment has no world model (plans asked for an object pose or the
    robot pose outside ``executive.environment(world=...)``). A programming error, not a
    plan failure."""

    cram_name = "no-world-model"


class NoRobotDescription(LookupError):
    """The current environment's world model carries no robot description (an in-memory
    test world built without ``robot=``), and a plan asked for the robot's arms, frames or
    named states. A programming error, not a plan failure."""

    cram_name = "no-robot-description"


class NoKitchenDescription(LookupError):
    """The current environment's world model carries no kitchen description (an in-memory
    test world built without ``kitchen=``), and a plan asked for the kitchen's surfaces,
    container, floor height or demo scene. A programming error, not a plan failure."""

    cram_name = "no-kitchen-description"


def cram_name_of(failure: BaseException | type[BaseException]) -> str:
    """CRAM's spelling of a failure (class or instance); the class name for others."""
    cls = failure if isinstance(failure, type) else type(failure)
    name = getattr(cls, "cram_name", None)
    return name if isinstance(name, str) else cls.__name__
