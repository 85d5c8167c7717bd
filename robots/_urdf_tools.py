"""Helpers for descriptions whose URDF is generated from a shipped one: read a URDF that
refers to its meshes by ``package://`` or relative paths, make those paths absolute (so the
generated file loads from anywhere), add links and joints, and write the result once per
content into a cache directory.

The generated files hold machine-specific absolute paths: they are written at load time,
never committed. Writing is atomic (a temporary file renamed into place), so two processes
generating the same URDF at once both end with the same complete file.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

__all__ = ["absolute_meshes", "cache_dir", "element", "write_cached"]


def cache_dir() -> Path:
    """Where generated URDFs go: ``$AIOCRAM_ROBOT_CACHE``, else a per-user directory in the
    system's temporary directory."""
    env = os.environ.get("AIOCRAM_ROBOT_CACHE")
    if env:
        return Path(env)
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(tempfile.gettempdir()) / f"aiocram-robots-{uid}"


def absolute_meshes(robot: ET.Element, package_dir: Path) -> None:
    """Rewrite every ``<mesh filename>`` of ``robot`` in place: ``package://P`` and relative
    paths become ``package_dir / P``. A mesh file that does not exist -> FileNotFoundError
    naming it (before anything is written)."""
    for mesh in robot.iter("mesh"):
        name = mesh.get("filename")
        if name is None:
            continue
        rel = name.removeprefix("package://")
        path = Path(rel) if Path(rel).is_absolute() else package_dir / rel
        if not path.is_file():
            raise FileNotFoundError(f"URDF mesh {name!r} not found at {path}")
        mesh.set("filename", str(path))


def element(tag: str, /, **attrs: str) -> ET.Element:
    """An XML element with string attributes (``name``, ``type``, ...)."""
    return ET.Element(tag, {k.rstrip("_"): v for k, v in attrs.items()})


def write_cached(text: str, stem: str) -> Path:
    """Write ``text`` to ``cache_dir()/stem-HASH.urdf`` unless that file exists; its path."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    directory = cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{stem}-{digest}.urdf"
    if path.is_file() and path.read_text() == text:
        return path
    fd, tmp = tempfile.mkstemp(dir=directory, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return path
