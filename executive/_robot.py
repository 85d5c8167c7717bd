"""Robot descriptions as data: what the plans may know about a robot's body (CRAM's
``cram_robot_interfaces`` facts; PyCRAM's ``RobotDescription``), as typed frozen records,
and their validation against the robot's kinematic tree (its URDF).

A :class:`RobotDescription` names, per part of the robot, the URDF joints and links the
plans and the world need: the :class:`ArmDescription` of each arm (its joint chain, tool
frame, the link a held object hangs from, the standard-gripper -> tool-frame rotation, its
:class:`GripperDescription`, its :class:`Reach` and its named configurations), the
:class:`TorsoDescription`, the :class:`NeckDescription` with its :class:`CameraDescription`,
and the base frame. Everything robot-specific lives in such a record, in a module beside
its URDF (the top-level ``robots`` package); nothing here names a robot.

Checking happens twice, both before anything moves:

- constructing a record checks what needs no URDF (arm names, a proper rotation, state
  lengths, limits in order) and raises :class:`RobotDescriptionError`;
- :meth:`RobotDescription.validate` checks the record against a :class:`KinematicTree` (from
  :meth:`KinematicTree.from_urdf`, or from a loaded PyBullet body in :mod:`projection`): every
  joint and link exists, each chain is a chain ending at its tool frame, the gripper joints
  hang below the arm, every named state is within the joint limits. Errors name the field
  (``arms['left'].joints[3]``), what is wrong and what to fix, with a did-you-mean.

Deliberate difference from CRAM: CRAM keeps these facts as Prolog clauses keyed by the
robot's name and fails silently (a query with no solution) when one is missing; here a
description is one value, checked as a whole when the robot is loaded, and a missing or
misspelt name is an error at that point rather than a failed query in the middle of a plan.
"""

from __future__ import annotations

import difflib
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

__all__ = [
    "ARM_NAMES",
    "REQUIRED_ARM_STATES",
    "ArmDescription",
    "CameraDescription",
    "GripperDescription",
    "JointInfo",
    "KinematicTree",
    "NeckDescription",
    "Reach",
    "RobotDescription",
    "RobotDescriptionError",
    "TorsoDescription",
]

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

#: CRAM's arm names: a one-armed robot calls its arm ``left`` (as CRAM's HSR, Donbot and
#: KMR descriptions do; cram-tf and the manipulation code know only these two).
ARM_NAMES: tuple[str, ...] = ("left", "right")
#: The named arm configurations the plans use: every arm must define them.
REQUIRED_ARM_STATES: tuple[str, ...] = ("park", "carry")
#: Joint kinds that move (URDF ``type``); ``fixed`` joints do not.
MOVABLE_KINDS: frozenset[str] = frozenset({"revolute", "prismatic", "continuous"})
#: How far (rad or m) a named state may lie outside the URDF limits (rounding).
LIMIT_TOLERANCE = 1e-6


class RobotDescriptionError(ValueError):
    """A robot description that does not fit its robot. Fields: ``robot`` (the
    description's name), ``field`` (where in the description, e.g.
    ``arms['left'].joints[3]``). The message says what is wrong and what to fix."""

    def __init__(self, robot: str, field: str, problem: str) -> None:
        super().__init__(f"robot description {robot!r}: {field}: {problem}")
        self.robot = robot
        self.field = field


def _did_you_mean(name: str, known: Sequence[str] | frozenset[str]) -> str:
    close = difflib.get_close_matches(name, sorted(known), n=3, cutoff=0.6)
    if close:
        return f"; did you mean {' or '.join(repr(c) for c in close)}?"
    return ""


# --------------------------------------------------------------------- kinematic tree
@dataclass(frozen=True)
class JointInfo:
    """One URDF joint: ``kind`` is the URDF type (fixed, revolute, prismatic, continuous,
    ...); ``lower``/``upper`` its limits (0, 0 for fixed; -inf, inf for continuous);
    ``effort`` its URDF effort limit (0 if none)."""

    name: str
    kind: str
    parent: str
    child: str
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0

    @property
    def movable(self) -> bool:
        """Whether the joint moves (not fixed)."""
        return self.kind in MOVABLE_KINDS


@dataclass(frozen=True)
class KinematicTree:
    """The joints and links of a robot model, by name: what a description is validated
    against. ``root`` is the link no joint moves (the base frame of a mobile robot)."""

    name: str
    root: str
    links: frozenset[str]
    joints: Mapping[str, JointInfo]
    # invariant: every joint's parent and child are in ``links``; each link but ``root``
    # is the child of exactly one joint (a tree)
    _parent_of: Mapping[str, JointInfo] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        parent_of: dict[str, JointInfo] = {}
        for j in self.joints.values():
            for end in (j.parent, j.child):
                if end not in self.links:
                    raise ValueError(f"joint {j.name!r} names an unknown link {end!r}")
            if j.child in parent_of:
                raise ValueError(f"link {j.child!r} is the child of two joints")
            parent_of[j.child] = j
        if self.root not in self.links or self.root in parent_of:
            raise ValueError(f"root {self.root!r} must be a link no joint has as child")
        object.__setattr__(self, "joints", MappingProxyType(dict(self.joints)))
        object.__setattr__(self, "_parent_of", MappingProxyType(parent_of))

    @classmethod
    def from_urdf(cls, urdf: str | Path) -> KinematicTree:
        """The tree of a URDF document (its text, or a path to it)."""
        text = urdf.read_text() if isinstance(urdf, Path) else urdf
        root_el = ET.fromstring(text)
        if root_el.tag != "robot":
            raise ValueError(f"not a URDF document: the root element is <{root_el.tag}>")
        links = frozenset(str(el.get("name")) for el in root_el.findall("link"))
        joints: dict[str, JointInfo] = {}
        for el in root_el.findall("joint"):
            name = str(el.get("name"))
            kind = str(el.get("type"))
            parent_el, child_el = el.find("parent"), el.find("child")
            if parent_el is None or child_el is None:
                raise ValueError(f"URDF joint {name!r} lacks <parent> or <child>")
            limit = el.find("limit")
            lower = upper = effort = 0.0
            if kind == "continuous":
                lower, upper = -math.inf, math.inf
            if limit is not None:
                effort = float(limit.get("effort", 0.0))
                if kind != "continuous":
                    lower = float(limit.get("lower", 0.0))
                    upper = float(limit.get("upper", 0.0))
            joints[name] = JointInfo(
                name,
                kind,
                str(parent_el.get("link")),
                str(child_el.get("link")),
                lower,
                upper,
                effort,
            )
        children = {j.child for j in joints.values()}
        roots = sorted(links - children)
        if len(roots) != 1:
            raise ValueError(f"a URDF must have exactly one root link, found {roots}")
        return cls(str(root_el.get("name")), roots[0], links, joints)

    def parent_joint(self, link: str) -> JointInfo | None:
        """The joint whose child is ``link`` (None for the root)."""
        return self._parent_of.get(link)

    def rigid_root(self, link: str) -> str:
        """The link ``link`` is rigidly attached to: walk up through fixed joints."""
        j = self._parent_of.get(link)
        while j is not None and not j.movable:
            link = j.parent
            j = self._parent_of.get(link)
        return link

    def is_below(self, link: str, ancestor: str) -> bool:
        """Whether ``ancestor`` is ``link`` or on its path to the root."""
        while True:
            if link == ancestor:
                return True
            j = self._parent_of.get(link)
            if j is None:
                return False
            link = j.parent


# ----------------------------------------------------------------------- the records
def _rotation(robot: str, where: str, rows: Mat3) -> Mat3:
    """``rows`` as floats; not a proper rotation (orthonormal, det +1) -> error."""
    m: tuple[tuple[float, ...], ...]
    try:
        m = tuple(tuple(float(v) for v in row) for row in rows)
        ok_shape = len(m) == 3 and all(len(r) == 3 for r in m)
    except (TypeError, ValueError):
        ok_shape = False
    if not ok_shape:
        raise RobotDescriptionError(robot, where, f"must be a 3x3 rotation (rows), got {rows!r}")
    for i in range(3):
        for k in range(3):
            dot = sum(m[i][n] * m[k][n] for n in range(3))
            if abs(dot - (1.0 if i == k else 0.0)) > 1e-6:
                raise RobotDescriptionError(
                    robot, where, f"rows must be orthonormal (a rotation), got {rows!r}"
                )
    a, b, c = m
    det = (
        a[0] * (b[1] * c[2] - b[2] * c[1])
        - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
    )
    if det < 0:
        raise RobotDescriptionError(robot, where, "is a reflection (det -1): swap two rows' signs")
    return m  # type: ignore[return-value]


@dataclass(frozen=True)
class GripperDescription:
    """A parallel gripper. ``joints``: every actuated finger joint, set together (PyBullet
    ignores URDF ``<mimic>``, so a mimicking joint is listed too); ``open_position`` /
    ``closed_position``: the joints' value at the widest opening and fully closed;
    ``max_opening``: the widest opening (m) between the finger pads (``setting-gripper``
    positions are checked against it); ``effort``: the default gripping effort (the URDF
    unit of the finger joints). The joint value for an opening is interpolated linearly
    between closed (0 m) and open (``max_opening``). ``finger_reach``: how far (m) the
    fingertips reach beyond the tool frame along the approach (0: the tool frame is at the
    tips); a grasp whose tool frame is ``d`` deep in an object holds ``d + finger_reach``
    of it between the fingers (the overhang grasp of :mod:`plans.overhang` sizes its depth
    by it). Negative or not finite: :class:`ValueError`."""

    joints: tuple[str, ...]
    max_opening: float
    open_position: float
    closed_position: float
    effort: float
    finger_reach: float = 0.0  # invariant: finite, >= 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.finger_reach) and self.finger_reach >= 0.0):
            raise ValueError(
                "GripperDescription.finger_reach must be a finite distance >= 0 (m): how "
                f"far the fingertips reach beyond the tool frame; got {self.finger_reach!r}"
            )

    def joint_position(self, opening: float) -> float:
        """The finger joints' value for ``opening`` metres (0..``max_opening``);
        outside -> :class:`ValueError` naming the range."""
        if not 0.0 <= opening <= self.max_opening:
            raise ValueError(f"gripper opening must be 0 to {self.max_opening} m, got {opening}")
        f = opening / self.max_opening
        return self.closed_position + f * (self.open_position - self.closed_position)


@dataclass(frozen=True)
class Reach:
    """What the ``reachable-for`` costmap needs of an arm (CRAM's
    ``costmap-in-reach-distance`` and ``costmap-reach-minimal-distance``): a base pose
    within ``in_reach_distance`` (m, 2-D, base frame origin to target) and no nearer than
    ``minimal_distance`` can reach the target."""

    in_reach_distance: float
    minimal_distance: float


@dataclass(frozen=True)
class ArmDescription:
    """One arm. ``name``: ``left`` or ``right`` (CRAM's names; a one-armed robot's arm is
    ``left``). ``joints``: the arm's movable joints, root to tip (the IK chain).
    ``tool_frame``: the link grasp poses are expressed in (rigidly attached to the last arm
    joint). ``hand_link``: the link a held object hangs from (rigid with the last arm joint
    too). ``standard_to_tool``: rows of the rotation from CRAM's standard gripper (z
    approaches the object, x from finger to finger) to the tool frame; grasps are written
    once for the standard gripper and combined with it. ``states``: named configurations,
    one value per joint of ``joints`` (must include :data:`REQUIRED_ARM_STATES`).
    ``ik_seeds``: optional joint configurations an IK solver starts from (after the arm's
    current one), one value per joint each (the world that loads the robot checks their
    lengths); empty: the solver uses the named states."""

    name: str
    joints: tuple[str, ...]
    tool_frame: str
    hand_link: str
    standard_to_tool: Mat3
    gripper: GripperDescription
    reach: Reach
    states: Mapping[str, tuple[float, ...]]
    ik_seeds: tuple[tuple[float, ...], ...] = ()

    def __post_init__(self) -> None:
        # invariant: joints a tuple, states a read-only mapping of float tuples, ik_seeds
        # a tuple of float tuples
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "ik_seeds", tuple(tuple(map(float, s)) for s in self.ik_seeds))
        object.__setattr__(
            self,
            "states",
            MappingProxyType({str(k): tuple(map(float, v)) for k, v in self.states.items()}),
        )

    def state(self, name: str) -> tuple[float, ...]:
        """The joint values of a named configuration; unknown -> :class:`LookupError`."""
        try:
            return self.states[name]
        except KeyError:
            raise LookupError(
                f"arm {self.name!r} has no configuration {name!r}; known: "
                f"{', '.join(self.states)}{_did_you_mean(name, tuple(self.states))}"
            ) from None


@dataclass(frozen=True)
class TorsoDescription:
    """The torso lift: a prismatic ``joint`` moved between ``lower`` and ``upper`` (m,
    within the URDF limits); ``default``: its height in a new world."""

    joint: str
    lower: float
    upper: float
    default: float


@dataclass(frozen=True)
class CameraDescription:
    """The camera: ``frame`` an optical frame (z forward, x right, y down), rigid with the
    neck's tilt link; ``vertical_fov`` / ``horizontal_fov`` its field of view (rad)."""

    frame: str
    vertical_fov: float
    horizontal_fov: float


@dataclass(frozen=True)
class NeckDescription:
    """A pan/tilt neck carrying the camera: ``pan_joint`` (yaw) then ``tilt_joint``
    (pitch), a chain; ``states``: named (pan, tilt) values, e.g. ``forward``."""

    pan_joint: str
    tilt_joint: str
    camera: CameraDescription
    states: Mapping[str, tuple[float, float]]

    def __post_init__(self) -> None:
        # invariant: states a read-only mapping of (pan, tilt) float pairs
        states = {str(k): tuple(map(float, v)) for k, v in self.states.items()}
        for k, v in states.items():
            if len(v) != 2:
                raise ValueError(f"neck state {k!r} must be (pan, tilt), got {v}")
        object.__setattr__(self, "states", MappingProxyType(states))


@dataclass(frozen=True)
class RobotDescription:
    """What the plans and the world know of one robot's body (see the module docstring).

    ``name``: the robot's name, the URDF's ``<robot name>`` (designators say
    ``reachable-for`` it). ``urdf``: a function returning the path of the URDF to load
    (it may generate the file). ``base_frame``: the URDF's root link, on the floor, that
    the world moves (a holonomic base: x, y, yaw). ``base_link``: the body of the base.
    ``arms``: one or two, the first one tried first. ``initial_state``: the named arm
    configuration of a new world."""

    name: str
    urdf: Callable[[], Path] = field(compare=False)
    base_frame: str
    base_link: str
    arms: tuple[ArmDescription, ...]
    torso: TorsoDescription
    neck: NeckDescription
    initial_state: str = "park"

    def __post_init__(self) -> None:
        r = self.name
        if not isinstance(r, str) or not r:
            raise RobotDescriptionError(str(r), "name", "must be a non-empty string")
        arms = tuple(self.arms)
        object.__setattr__(self, "arms", arms)
        if not 1 <= len(arms) <= 2:
            raise RobotDescriptionError(r, "arms", f"one or two arms, got {len(arms)}")
        seen: set[str] = set()
        for i, arm in enumerate(arms):
            where = f"arms[{i}]"
            if arm.name not in ARM_NAMES:
                raise RobotDescriptionError(
                    r,
                    f"{where}.name",
                    f"must be 'left' or 'right' (CRAM's names; a one-armed robot's arm is "
                    f"'left'), got {arm.name!r}",
                )
            if arm.name in seen:
                raise RobotDescriptionError(r, f"{where}.name", f"two arms named {arm.name!r}")
            seen.add(arm.name)
            self._check_arm(arm)
        self._check_torso_and_neck()
        for arm in arms:
            if self.initial_state not in arm.states:
                raise RobotDescriptionError(
                    r,
                    "initial_state",
                    f"unknown named state {self.initial_state!r}; arm {arm.name!r} defines "
                    f"{', '.join(arm.states)}"
                    f"{_did_you_mean(self.initial_state, tuple(arm.states))}",
                )

    def _check_arm(self, arm: ArmDescription) -> None:
        r, where = self.name, f"arms[{arm.name!r}]"
        if not arm.joints or len(set(arm.joints)) != len(arm.joints):
            raise RobotDescriptionError(
                r, f"{where}.joints", f"must be distinct joint names, root to tip; got {arm.joints}"
            )
        _rotation(r, f"{where}.standard_to_tool", arm.standard_to_tool)
        g = arm.gripper
        if not g.joints:
            raise RobotDescriptionError(r, f"{where}.gripper.joints", "name the finger joints")
        if not (0.0 < g.max_opening < 1.0):
            raise RobotDescriptionError(
                r, f"{where}.gripper.max_opening", f"must be in (0, 1) m, got {g.max_opening}"
            )
        if g.open_position == g.closed_position:
            raise RobotDescriptionError(
                r,
                f"{where}.gripper.open_position",
                "equals closed_position: the gripper could not open",
            )
        if not g.effort > 0.0:
            raise RobotDescriptionError(
                r, f"{where}.gripper.effort", f"must be positive, got {g.effort}"
            )
        reach = arm.reach
        if not 0.0 <= reach.minimal_distance < reach.in_reach_distance:
            raise RobotDescriptionError(
                r,
                f"{where}.reach",
                f"needs 0 <= minimal_distance < in_reach_distance, got {reach}",
            )
        states = arm.states
        for name in REQUIRED_ARM_STATES:
            if name not in states:
                raise RobotDescriptionError(
                    r,
                    f"{where}.states",
                    f"has no {name!r} configuration: the plans use "
                    f"{', '.join(REQUIRED_ARM_STATES)}",
                )
        for name, values in states.items():
            if len(values) != len(arm.joints):
                raise RobotDescriptionError(
                    r,
                    f"{where}.states[{name!r}]",
                    f"has {len(values)} values for {len(arm.joints)} joints "
                    f"({', '.join(arm.joints)})",
                )

    def _check_torso_and_neck(self) -> None:
        r, t = self.name, self.torso
        if not t.lower <= t.default <= t.upper or t.lower >= t.upper:
            raise RobotDescriptionError(
                r, "torso", f"needs lower < upper and lower <= default <= upper, got {t}"
            )
        neck = self.neck
        if "forward" not in neck.states:
            raise RobotDescriptionError(
                r, "neck.states", "has no 'forward' state (pan, tilt looking straight ahead)"
            )
        cam = neck.camera
        for name in ("vertical_fov", "horizontal_fov"):
            v = getattr(cam, name)
            if not 0.0 < v < math.pi:
                raise RobotDescriptionError(
                    r, f"neck.camera.{name}", f"must be in (0, pi) rad, got {v}"
                )

    # ------------------------------------------------------------------ lookups
    @property
    def arm_names(self) -> tuple[str, ...]:
        """The arms' names, in the order the plans try them."""
        return tuple(a.name for a in self.arms)

    def arm(self, name: str) -> ArmDescription:
        """The arm called ``name``; unknown -> :class:`LookupError` naming the known."""
        for a in self.arms:
            if a.name == name:
                return a
        raise LookupError(
            f"robot {self.name!r} has no arm {name!r}; known arms: {', '.join(self.arm_names)}"
        )

    def joint_state(self, name: str) -> Mapping[str, float]:
        """Every arm's named configuration ``name`` as joint -> value; an arm without it
        -> :class:`LookupError`."""
        out: dict[str, float] = {}
        for a in self.arms:
            out.update(zip(a.joints, a.state(name)))
        return MappingProxyType(out)

    # --------------------------------------------------------------- validation
    def validate(self, tree: KinematicTree) -> None:
        """Check the description against the robot model ``tree``; the first misfit ->
        :class:`RobotDescriptionError` naming the field and what to fix."""
        r = self.name
        if tree.name != self.name:
            raise RobotDescriptionError(
                r, "name", f"the URDF's robot is called {tree.name!r}: use that name"
            )
        if self.base_frame != tree.root:
            self._link(tree, "base_frame", self.base_frame)
            raise RobotDescriptionError(
                r,
                "base_frame",
                f"{self.base_frame!r} is not the URDF's root link {tree.root!r}: the world "
                "moves the root, so the base frame must be it",
            )
        self._link(tree, "base_link", self.base_link)
        t = self.torso
        tj = self._joint(tree, "torso.joint", t.joint, kinds=("prismatic",))
        self._within(tree, "torso", tj, (t.lower, t.upper, t.default))
        neck = self.neck
        self._chain(
            tree,
            {"neck.pan_joint": neck.pan_joint, "neck.tilt_joint": neck.tilt_joint},
            "neck.camera.frame",
            neck.camera.frame,
        )
        for name, values in neck.states.items():
            for jn, v in zip((neck.pan_joint, neck.tilt_joint), values):
                self._within(tree, f"neck.states[{name!r}]", tree.joints[jn], (v,))
        used: dict[str, str] = {t.joint: "torso.joint", neck.pan_joint: "neck.pan_joint"}
        used[neck.tilt_joint] = "neck.tilt_joint"
        for arm in self.arms:
            where = f"arms[{arm.name!r}]"
            chain = {f"{where}.joints[{i}]": jn for i, jn in enumerate(arm.joints)}
            self._chain(tree, chain, f"{where}.tool_frame", arm.tool_frame)
            tip = tree.joints[arm.joints[-1]].child
            self._link(tree, f"{where}.hand_link", arm.hand_link)
            if tree.rigid_root(arm.hand_link) != tree.rigid_root(tip):
                raise RobotDescriptionError(
                    r,
                    f"{where}.hand_link",
                    f"{arm.hand_link!r} is not rigidly attached to {tip!r}, the last arm "
                    "joint's link: a held object would not follow the arm",
                )
            for i, jn in enumerate(arm.joints):
                if jn in used:
                    raise RobotDescriptionError(
                        r, f"{where}.joints[{i}]", f"{jn!r} is already {used[jn]}"
                    )
                used[jn] = f"{where}.joints[{i}]"
            for state, joint_values in arm.states.items():
                for jn, v in zip(arm.joints, joint_values):
                    self._within(tree, f"{where}.states[{state!r}]", tree.joints[jn], (v,))
            g = arm.gripper
            for i, jn in enumerate(g.joints):
                fld = f"{where}.gripper.joints[{i}]"
                j = self._joint(tree, fld, jn)
                if jn in used:
                    raise RobotDescriptionError(r, fld, f"{jn!r} is already {used[jn]}")
                used[jn] = fld
                if not tree.is_below(j.parent, tip):
                    raise RobotDescriptionError(
                        r,
                        fld,
                        f"{jn!r} does not hang below the arm's last link {tip!r}: name this "
                        "arm's finger joints",
                    )
                self._within(tree, fld, j, (g.open_position, g.closed_position))
                if 0.0 < j.effort < g.effort:
                    raise RobotDescriptionError(
                        r,
                        f"{where}.gripper.effort",
                        f"{g.effort} exceeds the effort limit {j.effort} of {jn!r} in the URDF",
                    )

    def _link(self, tree: KinematicTree, fld: str, name: str) -> None:
        if name not in tree.links:
            raise RobotDescriptionError(
                self.name,
                fld,
                f"no link {name!r} in the URDF{_did_you_mean(name, tree.links)}",
            )

    def _joint(
        self,
        tree: KinematicTree,
        fld: str,
        name: str,
        kinds: tuple[str, ...] = tuple(sorted(MOVABLE_KINDS)),
    ) -> JointInfo:
        j = tree.joints.get(name)
        if j is None:
            raise RobotDescriptionError(
                self.name,
                fld,
                f"no joint {name!r} in the URDF{_did_you_mean(name, tuple(tree.joints))}",
            )
        if j.kind not in kinds:
            raise RobotDescriptionError(
                self.name, fld, f"joint {name!r} is {j.kind}, must be {' or '.join(kinds)}"
            )
        return j

    def _chain(
        self,
        tree: KinematicTree,
        joints: Mapping[str, str],
        tip_fld: str,
        tip: str,
    ) -> None:
        """``joints`` (field -> joint name, root to tip) form a chain, each joint's parent
        rigidly attached to the previous joint's child, and ``tip`` is rigid with the last
        joint's child."""
        fields = list(joints)
        infos = [self._joint(tree, f, jn) for f, jn in joints.items()]
        for k in range(1, len(infos)):
            prev, j = infos[k - 1], infos[k]
            if tree.rigid_root(j.parent) != prev.child:
                raise RobotDescriptionError(
                    self.name,
                    fields[k],
                    f"{j.name!r} does not follow {prev.name!r}: its parent link "
                    f"{j.parent!r} is not rigidly attached to {prev.child!r}; list the "
                    "joints in order from the root to the tip, one chain",
                )
        self._link(tree, tip_fld, tip)
        if tree.rigid_root(tip) != infos[-1].child:
            raise RobotDescriptionError(
                self.name,
                tip_fld,
                f"{tip!r} is not rigidly attached to {infos[-1].child!r}, the link of the "
                f"last joint {infos[-1].name!r}: the chain does not end at it",
            )

    def _within(self, tree: KinematicTree, fld: str, j: JointInfo, values: Sequence[float]) -> None:
        for v in values:
            if not j.lower - LIMIT_TOLERANCE <= v <= j.upper + LIMIT_TOLERANCE:
                raise RobotDescriptionError(
                    self.name,
                    fld,
                    f"{v} is outside the limits [{j.lower}, {j.upper}] of joint {j.name!r}",
                )
