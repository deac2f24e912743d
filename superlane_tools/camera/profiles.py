"""Bundled camera profiles and YAML camera files: load by name or path, dump to YAML."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel
from superlane_tools.config_files import load_document, parse_document
from superlane_tools.errors import ConfigError

_PROFILE_PACKAGE = "superlane_tools.camera"
_PROFILE_DIR = "profiles"
_SUFFIXES = (".yaml", ".yml")


class _FlowListDumper(yaml.SafeDumper):
    """Safe YAML dumper writing lists inline (``dist: [0.0, ...]``) and mappings as blocks."""


def _flow_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True)


_FlowListDumper.add_representer(list, _flow_list)


def list_profiles() -> list[str]:
    """Return the names of the bundled camera profiles, sorted."""
    folder = resources.files(_PROFILE_PACKAGE).joinpath(_PROFILE_DIR)
    return sorted(
        entry.name.rsplit(".", 1)[0]
        for entry in folder.iterdir()
        if entry.is_file() and entry.name.endswith(_SUFFIXES)
    )


def profile_text(name: str) -> str:
    """Return the YAML text of the bundled profile ``name``.

    Raises:
        CameraError: If no bundled profile has that name.
    """
    folder = resources.files(_PROFILE_PACKAGE).joinpath(_PROFILE_DIR)
    entry = folder.joinpath(f"{name}.yaml")
    if not entry.is_file():
        known = ", ".join(list_profiles())
        raise CameraError(f"unknown camera profile {name!r} (bundled: {known})")
    return entry.read_text(encoding="utf-8")


def camera_from_yaml(text: str, source: str = "<string>") -> CameraModel:
    """Parse a YAML camera description (the mapping of :meth:`CameraModel.to_dict`).

    Args:
        text: YAML document.
        source: Where the text came from, for error messages.

    Raises:
        CameraError: If the YAML is malformed or misses a field.
    """
    try:
        data = parse_document(text, source, ".yaml")
    except ConfigError as err:
        raise CameraError(str(err)) from err
    return _camera_from_data(data, source)


def _camera_from_data(data: Any, source: str) -> CameraModel:
    if not isinstance(data, dict):
        raise CameraError(f"{source}: expected a mapping with 'intrinsics' and 'extrinsics'")
    try:
        return CameraModel.from_dict(data)
    except CameraError as err:
        raise CameraError(f"{source}: {err}") from err


def camera_to_yaml(camera: CameraModel, comment: str = "") -> str:
    """Return the YAML text of ``camera`` (loadable by :func:`load_camera`).

    Args:
        camera: The camera to describe.
        comment: Optional text written as ``#`` comment lines at the top (provenance).
    """
    body = yaml.dump(camera.to_dict(), Dumper=_FlowListDumper, sort_keys=False)
    header = "".join(f"# {line}\n".replace("# \n", "#\n") for line in comment.splitlines())
    return header + body


def load_camera(name_or_path: str | os.PathLike[str]) -> CameraModel:
    """Load a camera from a bundled profile name (``sim_default``, ``tusimple``) or a YAML file.

    A value that names an existing file, or ends in ``.yaml``/``.yml``, or contains a path
    separator is read as a file; anything else is looked up among the bundled profiles.

    Raises:
        CameraError: If the profile is unknown, or the file is missing or invalid.
    """
    text = os.fspath(name_or_path)
    path = Path(text)
    looks_like_path = text.endswith(_SUFFIXES) or os.sep in text or "/" in text
    if path.is_file() or looks_like_path:
        try:
            data = load_document(path, "camera file", ".yaml")
        except ConfigError as err:
            raise CameraError(str(err)) from err
        return _camera_from_data(data, text)
    return camera_from_yaml(profile_text(text), source=f"profile {text}")
