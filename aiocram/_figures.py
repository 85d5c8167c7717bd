"""The demo's pictures that need to see the run as it happened: the head camera's view
at the last detection, and the base-pose costmaps as the robot used them.

Both are recorded by instruments while the run goes (after the run the objects have
moved and the robot stands elsewhere) and drawn at the end:

- :class:`CameraRecorder`: when a real (not imagined) ``detecting`` action succeeds, it
  takes a snapshot of the true world (cheap); :meth:`CameraRecorder.write` restores the
  last one for a moment, renders it from the robot's head camera, projects the detected
  objects' bounding boxes into the image and outlines and names them.
- :class:`CostmapRecorder`: when the real robot starts navigating to a costmap location
  (``visible-for`` / ``reachable-for``, or an ``(among ...)`` location whose poses a plan
  chose, e.g. by imagining), it notes the robot's pose and the objects as the robot
  believed them then, and it notes every imagined navigation's poses; at the end it
  finds the costmap each location's poses rest on and the imagined alternatives of the
  decision it ran inside, and draws :func:`aiocram._costmap_figure.costmap_figure`.

:func:`write_scene` draws the final scene: the world from a camera, every object in view
named.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import cpl

from ._costmap_figure import (
    _Alternative,
    _has_costmap,
    _Use,
    _xyyaw,
    base_half_extents,
    costmap_figure,
    draw_furniture,
    kitchen_boxes,
)
from ._views import imagined

__all__ = [
    "CameraRecorder",
    "CostmapRecorder",
    "costmap_figure",
    "draw_furniture",
    "kitchen_boxes",
    "write_scene",
]

_VIEW_SIZE = (640, 480)


def _matrix(values: Any) -> np.ndarray:
    """A PyBullet 16-float matrix (column-major) as a numpy 4x4."""
    return np.asarray(values, dtype=float).reshape(4, 4).T


def _names_in(result: Any) -> list[str]:
    items = result if isinstance(result, list | tuple) else [result]
    names = []
    for item in items:
        name = item.get("name") if hasattr(item, "get") else getattr(item, "name", None)
        if isinstance(name, str):
            names.append(name)
    return names


def _shoot(
    world: Any, camera: Any, names: Sequence[str]
) -> tuple[np.ndarray, list[tuple[str, tuple[float, float, float, float]]]]:
    """Render ``world`` from ``camera`` (:func:`projection.render.camera_image`) and
    project each named object's bounding box into the picture: the pixels and, per object
    in front of the camera and inside the frame, ``(name, (x0, y0, x1, y1))``."""
    from projection import render

    width, height = _VIEW_SIZE
    pixels, view, proj = render.camera_image(world, camera, width, height)
    m = _matrix(proj) @ _matrix(view)
    boxes = []
    for name in names:
        lo, hi = world.object_aabb(name)
        corners = np.array(
            [[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        clip = corners @ m.T
        if np.any(clip[:, 3] <= 1e-6):
            continue  # partly behind the camera
        ndc = clip[:, :3] / clip[:, 3:4]
        xs = (ndc[:, 0] + 1.0) / 2.0 * width
        ys = (1.0 - ndc[:, 1]) / 2.0 * height
        box = (
            float(np.clip(xs.min(), 0, width - 1)),
            float(np.clip(ys.min(), 0, height - 1)),
            float(np.clip(xs.max(), 0, width - 1)),
            float(np.clip(ys.max(), 0, height - 1)),
        )
        if box[2] - box[0] >= 1 and box[3] - box[1] >= 1:
            boxes.append((name, box))
    return pixels, boxes


def _tag(draw: Any, x: float, y: float, text: str, taken: list[tuple[float, ...]]) -> None:
    """A name tag centred above (x, y), moved up past the tags already drawn."""
    tw, th = 7 * len(text) + 8, 16
    x0 = min(max(x - tw / 2, 0), _VIEW_SIZE[0] - tw)
    y0 = max(y - th - 4, 0)
    while any(x0 < t[2] and t[0] < x0 + tw and y0 < t[3] and t[1] < y0 + th for t in taken):
        y0 -= th + 2
    y0 = max(y0, 0)
    taken.append((x0, y0, x0 + tw, y0 + th))
    draw.rectangle((x0, y0, x0 + tw, y0 + th), fill=(255, 255, 255), outline=(20, 20, 20))
    draw.text((x0 + 4, y0 + 2), text, fill=(0, 0, 0))


def write_scene(world: Any, path: Path, camera: Any, caption: str) -> Path:
    """The PNG of ``world`` from ``camera`` with every object in view named (a tag above
    it) and ``caption`` on a bar at the bottom, followed by how many objects are in view."""
    from PIL import Image, ImageDraw

    image, boxes = _shoot(world, camera, list(world.objects))
    img = Image.fromarray(image, "RGB")
    draw = ImageDraw.Draw(img)
    taken: list[tuple[float, ...]] = []
    for name, (x0, y0, x1, _y1) in sorted(boxes, key=lambda b: -b[1][1]):
        _tag(draw, (x0 + x1) / 2, y0, name, taken)
    draw.rectangle((0, img.height - 20, img.width, img.height), fill=(0, 0, 0))
    counted = f"{len(boxes)} of {len(world.objects)} objects in view, each named"
    draw.text((6, img.height - 16), f"{caption}: {counted}", fill=(255, 255, 255))
    img.save(path, format="PNG")
    return path


class CameraRecorder(cpl.Instrument):
    """Keeps the head camera's image at the last real detection (see the module
    docstring). ``detections`` counts the detections seen."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.detections = 0
        self.state: Any = None  # world snapshot at the last detection
        self.names: list[str] = []  # the objects detected then
        self.when: float | None = None

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if new is not cpl.Status.SUCCEEDED or imagined(task):
            return
        from executive import action_of

        action = action_of(task)
        if action is None or action.type != "detecting":
            return
        names = [n for n in _names_in(task.result) if n in self.world.objects]
        if not names:
            return
        self.detections += 1
        # a cheap copy of the true world now; the picture is rendered from it at the end
        self.state = self.world.snapshot()
        self.names = names
        self.when = task.end_time

    def _shoot(
        self, names: list[str]
    ) -> tuple[np.ndarray, list[tuple[str, tuple[float, float, float, float]]]]:
        return _shoot(self.world, "robot", names)

    def write(self, path: Path) -> Path:
        """The PNG: the last detection's image with each detected object outlined and
        named and a caption; without any detection, the camera's view now, captioned so."""
        from PIL import Image, ImageDraw

        if self.state is None:
            image, boxes = self._shoot([])
            caption = "head camera at the end of the run (the robot detected nothing)"
        else:
            now = self.world.snapshot()
            try:
                self.world.restore(self.state)
                image, boxes = self._shoot(self.names)
            finally:
                self.world.restore(now)
            seen = ", ".join(name for name, _ in boxes) or "an object outside the frame"
            t = f" at t={self.when:.1f} s" if self.when is not None else ""
            caption = f"head camera at the last detection{t}: {seen}"
        img = Image.fromarray(image, "RGB")
        draw = ImageDraw.Draw(img)
        for name, (x0, y0, x1, y1) in boxes:
            for k in range(3):
                draw.rectangle((x0 - k, y0 - k, x1 + k, y1 + k), outline=(255, 40, 40))
            tw = 7 * len(name) + 8
            ty = y0 - 18 if y0 >= 18 else y1 + 4
            draw.rectangle((x0 - 2, ty, x0 - 2 + tw, ty + 16), fill=(255, 40, 40))
            draw.text((x0 + 2, ty + 2), name, fill=(255, 255, 255))
        draw.rectangle((0, img.height - 20, img.width, img.height), fill=(0, 0, 0))
        draw.text((6, img.height - 16), caption, fill=(255, 255, 255))
        img.save(path, format="PNG")
        return path


def _plain(entries: Sequence[str]) -> tuple[str, ...]:
    """Task path entries without their ``#N`` repeat suffixes."""
    return tuple(e.split("#")[0] for e in entries)


class CostmapRecorder(cpl.Instrument):
    """Notes each real navigation to a costmap location (see the module docstring)."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.uses: list[_Use] = []
        self._by_chain: dict[int, _Use] = {}
        self._pending: dict[int, tuple[_Use, Any]] = {}
        #: every candidate pose the location pipeline generated, by chain (see
        #: :meth:`recording`); those that did not become solutions were rejected
        self.candidates: dict[int, list[tuple[float, float, float]]] = {}
        self.by_text: dict[str, list[tuple[float, float, float]]] = {}
        #: the costmap designators (chain firsts) the validator saw, by id: where the
        #: poses of an ``(among ...)`` location without ``(then ...)`` were drawn from
        self.designators: dict[int, Any] = {}
        #: imagined navigations: task -> the poses tried there and whether each succeeded
        self.imagined: dict[Any, list[tuple[tuple[float, float, float], bool]]] = {}
        self._imagined_pending: dict[int, tuple[Any, Any]] = {}

    def recording(self, rules: Any) -> Any:
        """A child of ``rules`` whose first location validator notes every candidate pose
        (and decides nothing): pass it as the run's rules to draw rejected samples."""
        child = rules.child("demo-costmap-recording")

        def note(d: Any, pose: Any) -> str:
            # by chain, and by the chain's text: plans resolve copies of the designator
            # they navigate by (e.g. a collision-checked one), whose chain is another
            first = d.first() if hasattr(d, "first") else d
            if getattr(pose, "frame", "map") == "map":
                xyyaw = _xyyaw(pose)
                self.candidates.setdefault(id(first), []).append(xyyaw)
                self.by_text.setdefault(repr(first), []).append(xyyaw)
                if _has_costmap(first):
                    self.designators[id(first)] = first
            return "unknown"

        child.register_location_validator(note, -1000)
        return child

    @staticmethod
    def _location(task: cpl.Task) -> Any:
        from executive import action_of

        action = action_of(task)
        if action is None or action.type != "navigating":
            return None
        loc = action.get("location")
        if loc is None or not hasattr(loc, "first") or loc.get("pose") is not None:
            return None
        return loc

    def task_status_changed(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        if imagined(task):
            self._imagined_status(task, old, new)
            return
        if new is cpl.Status.RUNNING and old is cpl.Status.CREATED:
            loc = self._location(task)
            if loc is None:
                return
            first = loc.first()
            use = self._by_chain.get(id(first))
            if use is None:
                use = self._new_use(task, first)
                self._by_chain[id(first)] = use
                self.uses.append(use)
            self._pending[id(task)] = (use, loc)
        elif new.dead and id(task) in self._pending:
            use, loc = self._pending.pop(id(task))
            member = loc.newest_effective() if hasattr(loc, "newest_effective") else None
            if member is not None:
                use.tries.append((_xyyaw(member.reference()), new is cpl.Status.SUCCEEDED))

    def _imagined_status(self, task: cpl.Task, old: cpl.Status, new: cpl.Status) -> None:
        """An imagined navigation: where it tried to stand and whether it got there (the
        costmap figures show the imagined alternatives next to the real choice)."""
        if new is cpl.Status.RUNNING and old is cpl.Status.CREATED:
            loc = self._location(task)
            if loc is not None:
                self._imagined_pending[id(task)] = (task, loc)
        elif new.dead and id(task) in self._imagined_pending:
            _, loc = self._imagined_pending.pop(id(task))
            member = loc.newest_effective() if hasattr(loc, "newest_effective") else None
            if member is not None:
                tried = (_xyyaw(member.reference()), new is cpl.Status.SUCCEEDED)
                self.imagined.setdefault(task, []).append(tried)

    def alternatives(self, use: _Use) -> list[_Alternative]:
        """The imagined alternatives of the decision ``use``'s first navigation ran inside
        (none outside one): the nearest enclosing task annotated with what was imagined,
        a transport's ``real-run`` (:class:`plans.reasoning.RunAssessment` records) or a
        search's ``chosen-viewpoint-K`` (:class:`plans.imagining.Imagined` records); each
        record's own subtree (its ``assessment`` / ``imagined`` annotation is that very
        record) holds the imagined navigation at the same place in the plan. The one the
        real robot went on with is the one whose first pose is the real location's."""
        from plans.imagining import Imagined
        from plans.reasoning import RunAssessment

        task = use.task
        decision = task.parent if task is not None else None
        records: tuple[Any, ...] = ()
        key = ""
        while decision is not None:
            notes = decision.annotations or {}
            runs, looks = notes.get("imagined"), notes.get("alternatives")
            if isinstance(runs, tuple) and runs and isinstance(runs[0], RunAssessment):
                records, key = runs, "assessment"
                break
            if isinstance(looks, tuple) and looks and isinstance(looks[0], Imagined):
                records, key = looks, "imagined"
                break
            decision = decision.parent
        if decision is None or decision.parent is None:
            return []
        where = _plain(task.path[len(decision.path) :])
        real_first = _among(use.location)
        out = []
        for sibling in decision.parent.children:
            record: Any = (sibling.annotations or {}).get(key)
            if record is None or not any(record is r for r in records):
                continue
            navs = [
                t
                for t in self.imagined
                if tuple(t.path[: len(sibling.path)]) == tuple(sibling.path)
                and _plain(t.path[len(sibling.path) :]) == where
            ]
            if not navs:
                continue
            tries = [tried for t in navs for tried in self.imagined[t]]
            first_loc = self._location(navs[0])
            region = _among(first_loc.first()) if first_loc is not None else []
            reached = next((p for p, ok in reversed(tries) if ok), None)
            if isinstance(record, RunAssessment):
                verdict = record.verdict()
            else:  # a viewpoint: its own pose first, then every other one as a fallback
                region = region[:1]
                if record.succeeded:
                    verdict = f"saw {record.value} search-region points"
                else:
                    verdict = f"fails ({record.outcome})"
            if isinstance(record, RunAssessment):  # the real run got its parameters
                chosen = record.params is (decision.annotations or {}).get("projected")
            else:  # the real location starts with the alternative's own pose
                chosen = bool(region and real_first and _close(region[0], real_first[0]))
            out.append(
                _Alternative(
                    str(record.name),
                    verdict,
                    region,
                    reached,
                    [p for p, ok in tries if not ok],
                    chosen,
                )
            )
        return out

    def _new_use(self, task: cpl.Task, first: Any) -> _Use:
        purpose, obj = "location", "?"
        for key, short in (("visible-for", "visible"), ("reachable-for", "reachable")):
            if first.get(key) is not None:
                purpose = short
        inner = first.get("location")
        target = inner.get("object") if inner is not None and hasattr(inner, "get") else None
        for candidate in (first.get("object"), target, first.get("for")):
            if candidate is not None and hasattr(candidate, "get"):
                obj = str(candidate.get("name") or candidate.get("type") or "?")
                break
        if obj == "?":
            obj = _object_of_step(task)
        step = next(
            (
                p.split("#")[0]
                for p in reversed(task.path)
                if p.split("#")[0]
                in ("search-for-object", "fetch", "deliver", "transport", "check-table")
            ),
            "navigate",
        )
        boxes = {}
        for name in self.world.objects:
            lo, hi = self.world.object_aabb(name)
            boxes[name] = (tuple(lo), tuple(hi))
        return _Use(
            first,
            obj,
            purpose,
            step,
            _xyyaw(self.world.robot_pose()),
            boxes,
            task=task,
            footprint=base_half_extents(self.world),
        )

    def figures(
        self, engine: Any, out_dir: Path, limit: int = 6, part: tuple[int, int] = (0, 1)
    ) -> list[Path]:
        """Draw up to ``limit`` figures, named ``costmap-K-STEP-OBJECT.png`` (``STEP``:
        search, fetch, deliver or check-table): the chains where a navigation failed first, then one
        per object and step. A figure that cannot be drawn is reported on
        stderr and skipped (a picture never fails the demo). ``part=(i, n)``: only the
        figures with ``(K - 1) % n == i`` (for drawing them in n processes at once)."""
        import sys

        # first, the chains where a navigation failed (the robot had to try another
        # pose: the pictures that show why), then one per (object, step), in run order
        chosen: list[_Use] = [u for u in self.uses if any(not ok for _, ok in u.tries)][:limit]
        seen = {(u.object, u.step) for u in chosen}
        for use in self.uses:
            if len(chosen) >= limit:
                break
            if (use.object, use.step) not in seen:
                seen.add((use.object, use.step))
                chosen.append(use)
        chosen.sort(key=self.uses.index)
        paths = []
        for k, use in enumerate(chosen, start=1):
            if (k - 1) % part[1] != part[0]:
                continue
            name = f"costmap-{k}-{_STEPS.get(use.step, use.step)}-{_slug(use.object)}.png"
            try:
                tried = self.candidates.get(id(use.location)) or self.by_text.get(
                    repr(use.location), []
                )
                paths.append(
                    costmap_figure(
                        engine,
                        use,
                        out_dir / name,
                        number=k,
                        candidates=tried,
                        alternatives=self.alternatives(use),
                        source=self.costmap_designator(use.location),
                    )
                )
            except Exception as exc:  # reported, and the demo goes on
                print(f"(costmap {name} not drawn: {type(exc).__name__}: {exc})", file=sys.stderr)
        return paths

    def costmap_designator(self, location: Any) -> Any:
        """The designator whose costmap ``location``'s poses come from: itself if it has a
        costmap key; for ``(among ...)`` its ``(then ...)`` fallback, or else the costmap
        designator the validator saw produce its first pose (a viewpoint's pool is drawn
        from the search's ``visible-for`` location); ``None`` if there is none."""
        seen: set[int] = set()
        while location is not None and id(location) not in seen:
            seen.add(id(location))
            if _has_costmap(location):
                return location
            fallback = location.get("then") if hasattr(location, "get") else None
            if fallback is None:
                break
            location = fallback.first() if hasattr(fallback, "first") else fallback
        poses = _among(location)
        if not poses:
            return None
        for key, designator in reversed(self.designators.items()):
            if any(_close(poses[0], p) for p in self.candidates.get(key, ())):
                return designator
        return None


def _among(location: Any) -> list[tuple[float, float, float]]:
    """The poses of an ``(among ...)`` location in the map frame (none otherwise)."""
    poses = location.get("among") if location is not None and hasattr(location, "get") else None
    if not isinstance(poses, tuple):
        return []
    return [_xyyaw(p) for p in poses if getattr(p, "frame", "map") == "map"]


def _close(p: Sequence[float], q: Sequence[float]) -> bool:
    return abs(p[0] - q[0]) < 1e-4 and abs(p[1] - q[1]) < 1e-4


def _object_of_step(task: Any) -> str:
    from executive import action_of

    t = task
    while t is not None:
        action = action_of(t)
        if action is not None and action.get("object") is not None:
            obj = action.get("object")
            return str(obj.get("name") or obj.get("type") or "?")
        t = t.parent
    return "?"


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c == "-" else "-" for c in text).strip("-") or "object"


_STEPS = {"search-for-object": "search", "transport": "transport"}
