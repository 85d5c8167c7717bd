"""``aiocram demo``: the table-setting demo as projection-then-execute on the simulated real
robot, and the pieces the robustness campaign (:mod:`aiocram.campaign`) shares with it.

Before each transport the robot imagines fetch-and-deliver ``runs`` times in projection
over its belief and executes the cheapest successful plan for real (``--no-projection``
turns that off). Outputs (``--out DIR``): ``log.jsonl`` (the event log; ``aiocram show
DIR/log.jsonl``), ``plans.log``, ``final_scene.png`` (the true world at the end, from a
camera that shows every object), ``robot_view.png`` (what the head camera sees),
``costmap-*.png`` (the base-pose costmaps the real run used, with the alternatives it
imagined) and ``floor_plan.png``.

One module per concept:

- :mod:`._config`: :class:`DemoConfig` (what to run, checked before anything moves or
  is written), the objects check and the flags the demo's and the campaign's parsers
  share;
- :mod:`._run`: :func:`run_demo` runs a plan (:func:`table_setting` unless one is
  passed: ``run_demo(config, plan=...)``) and gathers what it reports from outside
  the plan (events, instruments, the truth observer); :func:`run_demo_once` is the
  campaign's headless run;
- :mod:`._report`: :class:`DemoReport`, typed, and its JSON record, which the campaign
  aggregates (:func:`crash_record` for a run that never reported);
- :mod:`._outputs`: ``plans.log`` and the pictures; :mod:`._summary`: the console
  summary; :mod:`._cli`: the command.

**Adding a demo object** (one place): add its type to the
kitchen's ``demo_objects`` (``kitchens.iai.DESCRIPTION``, in the order it is set), with
CRAM's fixed spawning pose in its ``demo_poses`` (and, if it starts in a container, the
link in its ``demo_attachments``); the demo's and the campaign's
``--objects``, their checks and the scene (:func:`projection.set_up_scene`, which
samples a random scene's new type in CRAM's spawning region on the sink counter unless
``projection._scene.SPAWN_REGIONS`` narrows it) derive from that list. The object's type
(size, grasps) must be known to :mod:`projection` (``projection._objects``), and where the
plan fetches and places it is :func:`plans.demo.fetch_location` /
:func:`plans.demo.place_location` (the default applies to a type they do not name).
"""

from __future__ import annotations

from ._cli import add_parser
from ._config import (
    DEFAULT_OBJECTS,
    DEFAULT_ROBOT,
    DemoConfig,
    DemoConfigError,
    add_objects_argument,
    check_objects,
    robot_description,
    robot_names,
    whole,
)
from ._report import DemoReport, crash_record
from ._run import DemoPlan, frozen_imports, run_demo, run_demo_once, table_setting
from ._summary import outcome_table, print_report

__all__ = [
    "DEFAULT_OBJECTS",
    "DEFAULT_ROBOT",
    "DemoConfig",
    "DemoConfigError",
    "DemoPlan",
    "DemoReport",
    "add_objects_argument",
    "add_parser",
    "check_objects",
    "crash_record",
    "frozen_imports",
    "outcome_table",
    "print_report",
    "robot_description",
    "robot_names",
    "run_demo",
    "run_demo_once",
    "table_setting",
    "whole",
]
