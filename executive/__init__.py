"""executive: designators, their resolution, ``perform``, process modules, environments,
events and CRAM's common failures (CRAM's ``cram_executive``, ``cram_designators``,
``cram_process_modules``, ``cram_common_failures``).

Everything public is importable from here; the modules behind it are private except
``executive.events``, ``executive.retry``, ``executive.testing`` and ``executive.failures``.
"""

from . import _location, _motions, events
from ._blocking import BlockingProcessModule, CancelRequest
from ._designator import (
    ActionDesignator,
    Designator,
    LocationDesignator,
    MotionDesignator,
    ObjectDesignator,
    a,
    an,
    cram_key,
    equate,
)
from ._environment import (
    Environment,
    Imagination,
    Preferences,
    current_environment,
    environment,
    with_process_modules,
)
from ._kitchen import ContainerDescription, KitchenDescription, KitchenDescriptionError
from ._location import Validation
from ._perform import perform
from ._pose import Pose, Transform, yaw_quaternion
from ._process_module import PMStatus, ProcessModule, pm_execute
from ._queries import action_of, newest_effective, performed, previous_performed
from ._resources import Resource, ResourceKind
from ._robot import (
    ARM_NAMES,
    REQUIRED_ARM_STATES,
    ArmDescription,
    CameraDescription,
    GripperDescription,
    JointInfo,
    KinematicTree,
    NeckDescription,
    Reach,
    RobotDescription,
    RobotDescriptionError,
    TorsoDescription,
)
from ._ruledoc import Key, Retry, RuleDoc
from ._rules import (
    RuleSet,
    builtin_rules,
    register_location_generator,
    register_location_validator,
    register_resources,
    register_rule,
    rule,
    static_rules,
)
from ._solutions import ActionGrounding, MotionCommand, ObjectData
from ._world import (
    AABB,
    ArmJointLimits,
    ArmSweepProbe,
    ContainerOpeningProbe,
    ContainerStates,
    ObjectInventory,
    ObjectSpawning,
    ProbeResult,
    ProjectionWorld,
    SceneSetup,
    WorldModel,
    WorldProbes,
    WorldQueries,
)
from .events import emit, subscribe
from .failures import *  # noqa: F403
from .failures import __all__ as _failure_names
from .retry import (
    ListCursor,
    SolutionCursor,
    retry_scope,
    retry_with_designator_solutions,
    retry_with_list_solutions,
)

builtin_rules.freeze()
del _location, _motions

__all__ = [
    "AABB",
    "ARM_NAMES",
    "REQUIRED_ARM_STATES",
    "ArmDescription",
    "CameraDescription",
    "ContainerDescription",
    "GripperDescription",
    "JointInfo",
    "KitchenDescription",
    "KitchenDescriptionError",
    "KinematicTree",
    "NeckDescription",
    "Reach",
    "RobotDescription",
    "RobotDescriptionError",
    "TorsoDescription",
    "BlockingProcessModule",
    "CancelRequest",
    "ActionDesignator",
    "ActionGrounding",
    "Designator",
    "Environment",
    "ListCursor",
    "LocationDesignator",
    "MotionCommand",
    "MotionDesignator",
    "ObjectData",
    "ObjectDesignator",
    "PMStatus",
    "Pose",
    "ProcessModule",
    "Key",
    "Retry",
    "RuleDoc",
    "Resource",
    "ResourceKind",
    "RuleSet",
    "SolutionCursor",
    "Transform",
    "Validation",
    "Imagination",
    "Preferences",
    "ProbeResult",
    "ProjectionWorld",
    "ArmJointLimits",
    "ArmSweepProbe",
    "ContainerOpeningProbe",
    "ContainerStates",
    "ObjectInventory",
    "ObjectSpawning",
    "SceneSetup",
    "WorldModel",
    "WorldProbes",
    "WorldQueries",
    "a",
    "action_of",
    "an",
    "builtin_rules",
    "cram_key",
    "current_environment",
    "emit",
    "environment",
    "equate",
    "events",
    "newest_effective",
    "perform",
    "performed",
    "pm_execute",
    "previous_performed",
    "register_location_generator",
    "register_location_validator",
    "register_resources",
    "register_rule",
    "retry_scope",
    "retry_with_designator_solutions",
    "retry_with_list_solutions",
    "rule",
    "static_rules",
    "subscribe",
    "with_process_modules",
    "yaw_quaternion",
    *_failure_names,
]
