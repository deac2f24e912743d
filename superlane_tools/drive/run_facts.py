"""What a drive's report states about the run itself: its provenance lines and its camera.

:func:`run_header` gives the report's opening lines (tool version, command line, date, and the
licence of every model that ran, from its model card); :func:`camera_facts` reads which of the
camera's values are assumptions (the ``estimate:`` block ``slt camera estimate`` writes).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from superlane_tools.errors import SltError
from superlane_tools.reporting.drive_facts import CameraFacts
from superlane_tools.reporting.provenance import Provenance

_BESIDE = re.compile(r"camera profile (\S+) beside the recording")


def run_header(provenance: Provenance, when: datetime | None = None) -> tuple[str, ...]:
    """Return the report's opening bullets: version, command line, date (UTC), model licences.

    Args:
        provenance: The run's provenance (tool version, command line, models that ran).
        when: The report's time (default: now).
    """
    stamp = (when or datetime.now(UTC)).astimezone(UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    lines = [
        f"- tool: superlane-tools {provenance.tool_version}",
        f"- command: `{provenance.command}`",
        f"- date: {stamp}",
    ]
    licences = model_licences(provenance.models)
    if licences:
        lines += [f"- model {line}" for line in licences]
    else:
        lines.append("- models: none (no network ran)")
    return tuple(lines)


def model_licences(models: Mapping[str, str]) -> list[str]:
    """Return ``"NAME: licence"`` of every model that ran, from its model card.

    The card's ``training.licence`` when it states one, else the licences of its training
    data sets (a non-commercial one first and in capitals), else "not stated in its card".
    """
    return [f"{_bare(name)}: {_licence(_bare(name))}" for name in models]


def _bare(name: str) -> str:
    return name.removeprefix("onnx:")


def _licence(name: str) -> str:
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import resolve_model

    try:
        training = dict(load_card(resolve_model(name)[1]).training)
    except SltError:
        return "unknown (not a bundled model: see its card)"
    stated = training.get("licence")
    if isinstance(stated, str) and stated:
        return _mark(stated)
    sets = [d.get("licence") for d in training.get("datasets") or [] if isinstance(d, dict)]
    found = [str(s) for s in dict.fromkeys(sets) if s]
    if not found:
        return "not stated in its card"
    found.sort(key=lambda s: "non-commercial" not in s.lower())
    return _mark("training data: " + "; ".join(found))


def _mark(text: str) -> str:
    return f"NON-COMMERCIAL USE ONLY: {text}" if "non-commercial" in text.lower() else text


def camera_facts(camera: str, source: str, recording: Path) -> CameraFacts:
    """Return where the camera came from and which of its values are assumed.

    Args:
        camera: The ``--camera`` value (``auto``, a profile name or a YAML file).
        source: The sentence :func:`~superlane_tools.recording.calibration.resolve_camera`
            returned (it names a profile found beside the recording).
        recording: The recording.
    """
    path: Path | None = None
    if camera != "auto" and Path(camera).is_file():
        path = Path(camera)
    elif match := _BESIDE.search(source):
        path = recording.parent / match.group(1)
    if path is None or not path.is_file():
        return CameraFacts()
    from superlane_tools.config_files import load_document

    try:
        data = load_document(path, "camera profile", ".yaml")
    except SltError:
        return CameraFacts(profile=path.name)
    est: Any = data.get("estimate") if isinstance(data, dict) else None
    if not isinstance(est, dict):
        return CameraFacts(profile=path.name)
    # The height always comes from the assumed lane width (vanishing point, then the fit).
    width = float(est.get("lane_width_m", math.nan))
    intrinsics = str(est.get("intrinsics", ""))
    roll_method = str(est.get("roll_method", ""))
    estimated_roll = (
        bool(roll_method) and roll_method != "given" and "not estimated" not in roll_method
    )
    return CameraFacts(
        profile=path.name,
        lane_width_m=width,
        intrinsics=intrinsics,
        intrinsics_assumed="ASSUMED" in intrinsics and "MEASURED" not in intrinsics,
        roll_deg=float(est.get("roll_deg", math.nan)) if estimated_roll else math.nan,
        roll_frames=int(est.get("frames_used", 0)),
    )
