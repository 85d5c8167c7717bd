"""Knocked objects: every object a robot motion moved that was not its own pick-up or
placing, measured on the *true* world (issue 26, "no neighbour knocked").

The :class:`KnockWatcher` watches one run from outside the robot, as the
:class:`aiocram.truth.TruthObserver` does: it never reads the belief nor what a plan
reports, and never steps the physics. It takes a **checkpoint** of the true world at every
boundary of a real robot motion (a motion task of a process module starting or ending,
imagined runs left out) and at every world event that changes the true world
(``ObjectAttached``, ``ObjectDetached``, ``ContainerOpened``, ``ContainerClosed``).

Definition. Each free object (attached to nothing: neither held by the robot nor fixed to
a kitchen link, as the spoon to its drawer) has a *reference pose*: its true pose at the
first checkpoint at which it was free (the start of the run, or just after the robot
released it: the release's settling is part of the placing). At each checkpoint an object
whose true pose is more than :data:`KNOCK_DISTANCE` (2 cm) away from its reference, or
turned by more than :data:`KNOCK_ANGLE` (0.1 rad, 5.7 degrees, in any direction), moved;
the *causes* of the move are the real motions running in the interval since the previous
checkpoint (each with its motion type and arms) and the event of this checkpoint, if any.

- If some cause belongs to the object's **own** pick-up or placing (a motion inside a
  ``picking-up`` or ``placing`` action whose object is this object, or the release or
  grasp event of this object), or to a push of it (a ``pushing-object`` action whose
  object it is: the hand moves it on purpose), the move is not a knock: the reference
  is taken again.
  A placing's retract is inside the placing: an object placed unstably that falls while
  its own placing ends is **not** knocked (it is a placing failure, measured as toppled or
  not delivered by :mod:`aiocram.truth`); once its placing is over, it is an object at
  rest like any other.
- If the object was not at rest (:data:`AT_REST`, the speeds at which the simulated
  real robot stops stepping the physics) at the previous checkpoint, and no motion left
  the robot pressing into it (below), the move **continues** what set it moving (a
  knock: still rolling, sliding or falling from it, no new knock; its own placing; or a
  drift): a knocked cup rolling off the counter over three motions is one knock.
- Else, if some cause is a **pushing** motion (every motion type but ``detecting``, and
  the container events: a drawer opened or closed by the plan moves what stands in it or
  against it), the object was **knocked**: a :class:`Knock` is recorded (which object, by
  which motion and arm, inside which action, how far) and logged on the
  ``aiocram.knocks`` logger; the reference is taken again, so an object knocked twice is
  two knocks of one knocked object.
- Else (only perception ran, or nothing: physics caught up while the robot stood still)
  the object **drifted**: logged and counted apart (:attr:`KnockReport.drifted`), never
  silently dropped.

Limit: an object at rest that starts to fall by itself (one left balanced on a counter's
edge) while a motion runs is counted as knocked by that motion: the watcher sees the
true world only at checkpoints, not the contacts between them, and a fall from rest is
almost always a touch by the robot.

Tolerances. 2 cm and 0.1 rad are far above the jitter of an object resting in PyBullet
(below a millimetre and 0.01 rad over a whole run) and below what any object of the demo
can be pushed without being displaced for real: the narrowest (the spoon) is 2 cm wide,
and a tilt of 0.1 rad is well short of :data:`aiocram.truth.UPRIGHT_DEG` (15 degrees), so
a push that later topples an object is seen when it starts. Projection reasoning's own
knock test (:class:`plans.reasoning.Ranking`, 3 cm / 0.35 rad) is looser because
imagined motions teleport and an imagined world is not settled physics.

Attribution limit. The simulated real robot catches physics up at the start of every
motion step, so the push of a motion's very last control step (one
``projection`` ``CONTROL_PERIOD`` of arm travel) shows at the next motion's first step and
is attributed to that next motion. A sweep through an object moves it during the
sweeping motion itself, well beyond the tolerance, and is attributed right.

Deliberate difference from CRAM: CRAM has no such measure (its projection checks the
believed neighbours after an imagined action); this one is the campaign's ground truth.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import cpl

__all__ = [
    "KNOCK_ANGLE",
    "KNOCK_DISTANCE",
    "Knock",
    "KnockReport",
    "KnockWatcher",
    "Motion",
]

log = logging.getLogger("aiocram.knocks")

#: Displacement (m) of an object's true position beyond which it moved.
KNOCK_DISTANCE = 0.02
#: Rotation (rad, about any axis) of an object's true orientation beyond which it moved.
KNOCK_ANGLE = 0.1
#: Distance (m) within which the robot (or an object it holds) touches an object at the
#: end of a motion.
TOUCH_DISTANCE = 0.001
#: Linear (m/s) and angular (rad/s) speeds below which an object is at rest: those at which
#: the simulated real robot stops stepping the physics (``projection._real_body``).
AT_REST = (1e-3, 1e-2)
#: Motion types that cannot push anything (the camera only looks).
STILL_MOTIONS = frozenset({"detecting"})
#: When several causes ran in one interval, the knock names the first of this order (the
#: one that sweeps the most space: an arm, then the base, ...); the rest are ``others``.
PUSH_ORDER = (
    "moving-tcp",
    "moving-arm-joints",
    "going",
    "moving-torso",
    "container-opening-event",
    "container-closing-event",
    "object-detached",
    "object-attached",
)
#: Actions an object's own motions are inside (its pick-up, its placing, a push of it:
#: ``pushing-object`` moves it on purpose, issue 26).
OWN_ACTIONS = frozenset({"picking-up", "placing", "pushing-object"})


@dataclass(frozen=True)
class Motion:
    """A cause of a move: a real motion (``kind`` its motion type, e.g. ``moving-tcp``)
    or a world event (``kind`` its CRAM name, e.g. ``container-opening-event``).
    ``arms``: the arms it moves or that act (empty for the base, torso, head, a drawer);
    ``action``: the type of the innermost performed action on an object it is part of
    (else of the innermost action) and ``subject`` that action's object (None: none);
    ``own``: the objects whose own pick-up or placing it is part of; ``step``: the type
    of the innermost action (``reaching``, ``lifting``, ...)."""

    kind: str
    arms: tuple[str, ...] = ()
    action: str | None = None
    subject: str | None = None
    own: frozenset[str] = frozenset()
    step: str | None = None

    @property
    def pushes(self) -> bool:
        """Whether this cause can move an object (every motion but perception)."""
        return self.kind not in STILL_MOTIONS

    def describe(self) -> str:
        """``moving-tcp (right arm) reaching in picking-up cup-1``."""
        text = self.kind
        if self.arms:
            text += f" ({'+'.join(self.arms)} arm{'s' if len(self.arms) > 1 else ''})"
        if self.step is not None and self.step != self.action:
            text += f" {self.step}"
        if self.action is not None:
            text += f" in {self.action}" + (f" {self.subject}" if self.subject else "")
        return text


@dataclass(frozen=True)
class Knock:
    """Object ``object`` moved ``distance`` m and turned ``angle`` rad from its reference
    pose while ``motion`` ran (``others``: further causes in the same interval) and no
    cause was its own pick-up or placing. ``at``: the loop's time of the checkpoint (s,
    simulated). ``where``: the reference and the new position."""

    object: str
    motion: Motion
    distance: float
    angle: float
    at: float
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    others: tuple[Motion, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "object": self.object,
            "motion": self.motion.kind,
            "arms": list(self.motion.arms),
            "action": self.motion.action,
            "subject": self.motion.subject,
            "step": self.motion.step,
            "by": self.motion.describe(),
            "others": [m.describe() for m in self.others],
            "distance": round(self.distance, 3),
            "angle": round(self.angle, 3),
            "at": round(self.at, 2),
            "start": [round(v, 3) for v in self.start],
            "end": [round(v, 3) for v in self.end],
        }


@dataclass
class KnockReport:
    """The run's knocks (each move of an object by a motion not its own pick-up or
    placing) and drifts (moves while no motion that pushes ran)."""

    knocks: list[Knock] = field(default_factory=list)
    drifted: list[str] = field(default_factory=list)
    #: objects moved by their own pick-up or placing (not knocks), once per move
    own: list[str] = field(default_factory=list)

    @property
    def knocked(self) -> list[str]:
        """The knocked objects, each once, in the order they were first knocked."""
        return list(dict.fromkeys(k.object for k in self.knocks))

    def to_json(self) -> dict[str, Any]:
        return {
            "knocked": self.knocked,
            "knocks": [k.to_json() for k in self.knocks],
            "drifted": list(self.drifted),
            "own": list(self.own),
        }


def _angle(q0: Iterable[float], q1: Iterable[float]) -> float:
    """The rotation angle (rad) between two unit quaternions."""
    dot = abs(sum(a * b for a, b in zip(q0, q1, strict=True)))
    return 2.0 * math.acos(min(1.0, dot))


def _name(obj: Any) -> str | None:
    from executive.events import object_name

    try:
        return object_name(obj)
    except (ValueError, TypeError, AttributeError):
        return None


def _motion_arms(motion: Any) -> tuple[str, ...]:
    """The arms a motion designator names: ``gripper``, or ``<arm>-pose`` /
    ``<arm>-joint-states`` style keys (the arm is the key's first word)."""
    gripper = motion.get("gripper")
    if gripper is not None:
        return tuple(gripper) if isinstance(gripper, tuple) else (str(gripper),)
    arms: list[str] = []
    for key, value in motion.properties:
        if value is None or not isinstance(key, str) or "-" not in key:
            continue
        side, rest = key.split("-", 1)
        if rest in ("pose", "target", "joint-states", "configuration") and side not in arms:
            arms.append(side)
    return tuple(arms)


def _context(task: cpl.Task) -> tuple[str | None, str | None, str | None, frozenset[str]]:
    """Above ``task``: the innermost performed action (its type, the step), the innermost
    one that acts on an object (type and object name), and the objects whose own pick-up
    or placing ``task`` is inside."""
    from executive import action_of

    step: str | None = None
    action: str | None = None
    subject: str | None = None
    own: set[str] = set()
    t: cpl.Task | None = task
    while t is not None:
        desig = action_of(t)
        if desig is not None:
            kind = str(desig.type)
            obj = desig.get("object")
            name = None if obj is None else _name(obj)
            if step is None:
                step = kind
            if action is None and name is not None:
                action, subject = kind, name
            if kind in OWN_ACTIONS and name is not None:
                own.add(name)
        t = t.parent
    if action is None:
        action = step
    return step, action, subject, frozenset(own)


class KnockWatcher(cpl.Instrument):
    """Counts the knocked objects of one run on ``true_world`` (see the module
    docstring). Add it to the run's instruments and call :meth:`subscribe` once the
    robot's environment is active; :meth:`report` after the run."""

    def __init__(
        self,
        true_world: Any,
        *,
        distance: float = KNOCK_DISTANCE,
        angle: float = KNOCK_ANGLE,
    ) -> None:
        for label, value in (("distance", distance), ("angle", angle)):
            if not isinstance(value, int | float) or not value > 0:
                raise ValueError(f"KnockWatcher({label}=...) is a number > 0, got {value!r}")
        self.true_world = true_world
        self.distance = float(distance)
        self.angle = float(angle)
        #: name -> (position, orientation) the object is measured against; absent while it
        #: is attached (held, or fixed to a kitchen link) or before the first checkpoint
        self._reference: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {}
        #: motion task -> its Motion; invariant: exactly the real motions started, not dead
        self._active: dict[cpl.Task, Motion] = {}
        #: free object -> the first real motion that ended with the robot (or what it
        #: holds) touching it; invariant: only objects touched at the last motion end
        #: that have not moved since
        self._pressed: dict[str, Motion] = {}
        #: free object -> what set it moving (a Knock, "own" or "drift"); invariant: the
        #: objects not at rest at the last checkpoint that moved beyond the tolerance
        #: since they last were (an object found at rest leaves it)
        self._in_motion: dict[str, Knock | str] = {}
        #: free objects not at rest at the last checkpoint
        self._restless: set[str] = set()
        self._report = KnockReport()

    # -- the run's hooks -----------------------------------------------------------
    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        annotations = task.annotations
        if not annotations or "motion" not in annotations:
            return
        if new is cpl.Status.RUNNING and task not in self._active:
            if cpl.within(task, cpl.Subtree.IMAGINED):
                return
            self.checkpoint()
            motion = annotations["motion"]
            step, action, subject, own = _context(task)
            self._active[task] = Motion(
                str(motion.type), _motion_arms(motion), action, subject, own, step
            )
        elif new.dead and task in self._active:
            self.checkpoint()
            motion = self._active.pop(task)
            touched = self._touching()
            self._pressed = {n: self._pressed.get(n, motion) for n in touched}

    def subscribe(self, env: Any) -> Callable[[], None]:
        """Take the first checkpoint and watch the events that change the true world in
        ``env`` (the real robot's environment). Returns a function that unsubscribes."""
        from executive.events import (
            ContainerClosed,
            ContainerOpened,
            ObjectAttached,
            ObjectDetached,
        )

        def held(event: ObjectAttached | ObjectDetached) -> None:
            name = _name(event.object)
            own = frozenset() if name is None else frozenset({name})
            self.checkpoint(Motion(event.cram_name, (event.arm,), None, name, own))

        def container(event: ContainerOpened | ContainerClosed) -> None:
            self.checkpoint(Motion(event.cram_name, (), None, _name(event.container)))

        self.checkpoint()
        undo = [
            env.subscribe(ObjectAttached, held),
            env.subscribe(ObjectDetached, held),
            env.subscribe(ContainerOpened, container),
            env.subscribe(ContainerClosed, container),
        ]

        def unsubscribe() -> None:
            for u in undo:
                u()

        return unsubscribe

    # -- measuring -------------------------------------------------------------------
    def checkpoint(self, event: Motion | None = None) -> None:
        """Compare every free object of the true world with its reference; ``event``: the
        world event that just changed the true world (a cause besides the motions
        running)."""
        world = self.true_world
        causes = list(self._active.values())
        if event is not None:
            causes.append(event)
        attached = world.attachments
        restless = self._moving_now()
        for name in list(world.objects):
            if name in attached:
                self._reference.pop(name, None)
                self._pressed.pop(name, None)
                self._in_motion.pop(name, None)
                continue
            pose = world.object_pose(name)
            position = tuple(float(v) for v in pose.position)
            orientation = tuple(float(v) for v in pose.orientation)
            ref = self._reference.get(name)
            self._reference[name] = (position, orientation)
            if ref is None:  # free from now on: released, or the first checkpoint
                if name in restless:  # still settling, from its own release or the scene's
                    own = any(name in c.own for c in causes)
                    self._in_motion[name] = "own" if own else "drift"
                continue
            moved = math.dist(ref[0], position)
            turned = _angle(ref[1], orientation)
            if moved <= self.distance and turned <= self.angle:
                self._reference[name] = ref  # still at rest: keep the reference
            else:
                self._moved(name, causes, ref[0], position, moved, turned)
            if name not in restless:
                self._in_motion.pop(name, None)  # at rest again: the next move is new
        self._restless = restless
        for name in list(self._reference):
            if name not in world.objects:
                del self._reference[name]

    def _moved(
        self,
        name: str,
        causes: list[Motion],
        start: tuple[float, ...],
        end: tuple[float, ...],
        moved: float,
        turned: float,
    ) -> None:
        pressed = self._pressed.pop(name, None)
        if pressed is None and name in self._restless:
            # it was moving already when the interval began: still falling, sliding or
            # rolling from what set it moving, no new knock
            what = self._in_motion.setdefault(name, "drift")
            if what == "drift":
                self._report.drifted.append(name)
            elif what == "own":
                self._report.own.append(name)
            log.info(
                "%s moved %.3f m, turned %.2f rad, moving since before (%s)",
                name,
                moved,
                turned,
                what if isinstance(what, str) else f"knocked by {what.motion.describe()}",
            )
            return
        if pressed is not None:  # left pressed by a motion that ended before
            causes = [pressed, *(c for c in causes if c is not pressed)]
        if any(name in c.own for c in causes):
            self._report.own.append(name)  # its own pick-up or placing
            self._in_motion[name] = "own"
            log.debug("%s moved %.3f m by its own pick-up or placing", name, moved)
            return
        rank = {kind: i for i, kind in enumerate(PUSH_ORDER)}
        pushing = sorted((c for c in causes if c.pushes), key=lambda c: rank.get(c.kind, len(rank)))
        if not pushing:
            self._report.drifted.append(name)
            self._in_motion[name] = "drift"
            log.info(
                "%s moved %.3f m, turned %.2f rad while no motion pushed (%s): drifted",
                name,
                moved,
                turned,
                ", ".join(c.describe() for c in causes) or "the robot stood still",
            )
            return
        import asyncio

        try:
            now = asyncio.get_running_loop().time()
        except RuntimeError:  # measured outside a run
            now = 0.0
        knock = Knock(
            name,
            pushing[0],
            moved,
            turned,
            now,
            (start[0], start[1], start[2]),
            (end[0], end[1], end[2]),
            tuple(pushing[1:]),
        )
        self._report.knocks.append(knock)
        self._in_motion[name] = knock
        log.warning(
            "%s knocked by %s: moved %.3f m, turned %.2f rad%s",
            name,
            knock.motion.describe(),
            moved,
            turned,
            "".join(f"; also running: {m.describe()}" for m in knock.others),
        )

    def _moving_now(self) -> set[str]:
        """The free objects of the true world not at rest (:data:`AT_REST`): a read of
        their velocities."""
        import pybullet as pb

        world = self.true_world
        c = world.client
        lin_eps, ang_eps = AT_REST
        out = set()
        attached = world.attachments
        for name in world.objects:
            if name in attached:
                continue
            lin, ang = pb.getBaseVelocity(world.body_of(name), physicsClientId=c)
            if math.hypot(*lin) > lin_eps or math.hypot(*ang) > ang_eps:
                out.add(name)
        return out

    def _touching(self) -> set[str]:
        """The free objects the true robot, or an object it holds, touches now (a
        distance query: the physics is left as it is)."""
        import pybullet as pb

        world = self.true_world
        c, robot = world.client, world.robot_body
        attached = world.attachments
        bodies = [robot]
        bodies += [world.body_of(n) for n, link in attached.items() if link in world.robot_links]
        out = set()
        for name in world.objects:
            if name in attached:
                continue
            body = world.body_of(name)
            if any(pb.getClosestPoints(b, body, TOUCH_DISTANCE, physicsClientId=c) for b in bodies):
                out.add(name)
        return out

    def report(self) -> KnockReport:
        """The knocks and drifts so far (a final checkpoint is taken first)."""
        self.checkpoint()
        return self._report
