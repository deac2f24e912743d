"""The one loader of mapping files (TOML, YAML, JSON) behind every config and manifest."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from superlane_tools.errors import ConfigError

FORMATS = {".toml": "TOML", ".json": "JSON", ".yaml": "YAML", ".yml": "YAML"}


def load_document(path: str | os.PathLike[str], what: str = "config", suffix: str = "") -> Any:
    """Read and parse a TOML, JSON or YAML file, chosen by its suffix (YAML when unknown).

    Args:
        path: The file.
        what: What the file is, for error messages (``config``, ``manifest``...).
        suffix: Parse as this suffix whatever the file's name ("": the file's own suffix).

    Returns:
        The parsed document (an empty YAML file gives None).

    Raises:
        ConfigError: If the file cannot be read or parsed.
    """
    src = Path(path)
    try:
        text = src.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"cannot read {what} {src}: {err}") from err
    return parse_document(text, str(src), suffix or src.suffix)


def parse_document(text: str, source: str, suffix: str = ".yaml") -> Any:
    """Parse TOML, JSON or YAML text (a bundled resource, a file already read).

    Args:
        text: The document.
        source: Where it came from, for error messages (a path, ``profile NAME``).
        suffix: Its format by file suffix (YAML when unknown).

    Returns:
        The parsed document (an empty YAML document gives None).

    Raises:
        ConfigError: If the text is not valid in its format.
    """
    kind = FORMATS.get(suffix.lower(), "YAML")
    try:
        if kind == "TOML":
            import tomllib

            return tomllib.loads(text)
        if kind == "JSON":
            import json

            return json.loads(text)
        import yaml

        # libyaml's safe loader when built in (about 10x faster: model cards, profiles)
        return yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except Exception as err:  # TOMLDecodeError, JSONDecodeError, YAMLError
        raise ConfigError(f"{source}: not valid {kind}: {err}") from err


def load_mapping(
    path: str | os.PathLike[str], what: str = "config", suffix: str = ""
) -> dict[str, Any]:
    """Read a TOML, JSON or YAML file that must hold a mapping (an empty file is ``{}``).

    Raises:
        ConfigError: If the file cannot be read or parsed, or is not a mapping.
    """
    data = load_document(path, what, suffix)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: the {what} must be a mapping")
    return data
