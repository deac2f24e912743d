"""Model cards: the YAML beside every ONNX model saying what it takes, returns and achieves.

A card (``MODEL.card.yaml`` beside ``MODEL.onnx``) holds the model's name and task, its training
data and exact commands, the input spec (size, channels, colour order, normalisation), the output
heads with their class map onto the hierarchy, the parameter count, the sha256 of the ONNX file,
measured accuracy and milliseconds per frame. Loading a model checks the file's sha256 and the
session's input/output names and shapes against the card and refuses any mismatch, so a user can
plug in their own ONNX model by writing a card for it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import yaml

from superlane_tools.config_files import load_document
from superlane_tools.errors import ConfigError
from superlane_tools.reporting.atomic import write_text_atomic
from superlane_tools.reporting.provenance import file_sha256
from superlane_tools.scene.adapters.heads import Head, validate_heads
from superlane_tools.scene.model_errors import ModelError

TASKS = ("segmentation", "corridor")
COLOR_ORDERS = ("RGB", "BGR", "GRAY")
CARD_SUFFIX = ".card.yaml"


@dataclass(frozen=True)
class InputSpec:
    """What the network takes: one ``(1, C, H, W)`` float32 tensor.

    Pixels are scaled to ``[0, 1]`` (divided by 255), then normalised per channel as
    ``(x - mean) / std``.

    Attributes:
        name: Input name in the ONNX graph.
        width: Input width in pixels.
        height: Input height in pixels.
        color_order: ``RGB``, ``BGR`` or ``GRAY`` (one channel).
        mean: Per-channel mean on the ``[0, 1]`` scale.
        std: Per-channel standard deviation on the ``[0, 1]`` scale.
    """

    name: str
    width: int
    height: int
    color_order: str = "RGB"
    mean: tuple[float, ...] = (0.5, 0.5, 0.5)
    std: tuple[float, ...] = (0.25, 0.25, 0.25)

    @property
    def channels(self) -> int:
        """Number of input channels."""
        return 1 if self.color_order == "GRAY" else 3

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """The static ``(N, C, H, W)`` input shape."""
        return (1, self.channels, self.height, self.width)


@dataclass(frozen=True)
class OutputSpec:
    """One output tensor of the network.

    Attributes:
        name: Output name in the ONNX graph.
        kind: ``logits`` (a softmax head), or ``probability`` (corridor, ``(1, 1, H, W)``).
        parent: Hierarchy node the head refines (``""`` for the root head).
        classes: Hierarchy node names of the channels, in channel order (heads only).
    """

    name: str
    kind: str = "logits"
    parent: str = ""
    classes: tuple[str, ...] = ()

    def head(self) -> Head:
        """Return the output as a hierarchy :class:`Head`."""
        return Head(self.name, self.parent, self.classes)


@dataclass(frozen=True)
class ModelCard:
    """Everything a runtime and a reader need to know about one ONNX model.

    Attributes:
        name: Model name (bundled models: the file stem, e.g. ``super_seg_v2``).
        task: ``segmentation`` or ``corridor``.
        input: The input spec.
        outputs: The outputs, heads in decoding order (parents before children).
        sha256: Hex SHA-256 of the ONNX file.
        parameters: Trainable parameter count.
        description: What the model is and is not.
        training: Training data and exact commands (dataset command, training command, seed...).
        metrics: Measured accuracy, e.g. ``{"sim_heldout": {...}, "real": {...}}``.
        ms_per_frame: Median onnxruntime milliseconds per frame and how they were measured.
    """

    name: str
    task: str
    input: InputSpec
    outputs: tuple[OutputSpec, ...]
    sha256: str = ""
    parameters: int = 0
    description: str = ""
    training: Mapping[str, Any] = field(default_factory=dict)
    metrics: Mapping[str, Any] = field(default_factory=dict)
    ms_per_frame: Mapping[str, Any] = field(default_factory=dict)

    def heads(self) -> tuple[Head, ...]:
        """Return the segmentation heads in decoding order."""
        return tuple(o.head() for o in self.outputs if o.kind == "logits")

    def to_dict(self) -> dict[str, Any]:
        """Return the YAML-ready mapping of the card."""
        return {
            "name": self.name,
            "task": self.task,
            "description": self.description,
            "sha256": self.sha256,
            "parameters": self.parameters,
            "input": {
                "name": self.input.name,
                "width": self.input.width,
                "height": self.input.height,
                "channels": self.input.channels,
                "color_order": self.input.color_order,
                "layout": "NCHW float32, pixel / 255 then (x - mean) / std",
                "mean": list(self.input.mean),
                "std": list(self.input.std),
            },
            "outputs": [
                {"name": o.name, "kind": o.kind, "parent": o.parent, "classes": list(o.classes)}
                for o in self.outputs
            ],
            "training": dict(self.training),
            "metrics": dict(self.metrics),
            "ms_per_frame": dict(self.ms_per_frame),
        }

    def to_yaml(self) -> str:
        """Return the card as YAML text."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=False, width=100)


def card_path_for(model_path: str | os.PathLike[str]) -> Path:
    """Return the card path beside a model: ``MODEL.onnx`` -> ``MODEL.card.yaml``."""
    path = Path(model_path)
    return path.with_name(path.name.removesuffix(".onnx") + CARD_SUFFIX)


def _floats(value: Any, what: str, n: int, source: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise ModelError(f"{source}: {what} must be a list of numbers") from err
    if len(out) != n:
        raise ModelError(f"{source}: {what} needs {n} values (one per channel), got {len(out)}")
    if what == "input.std" and any(v <= 0 for v in out):
        raise ModelError(f"{source}: input.std must be positive")
    return out


def card_from_dict(data: Any, source: str = "<card>") -> ModelCard:
    """Build and validate a card from its parsed YAML mapping.

    Raises:
        ModelError: If a field is missing, has the wrong type, or the heads are inconsistent.
    """
    if not isinstance(data, dict):
        raise ModelError(f"{source}: a model card must be a YAML mapping")
    try:
        task = str(data["task"])
        raw_in = data["input"]
        order = str(raw_in.get("color_order", "RGB")).upper()
        if order not in COLOR_ORDERS:
            raise ModelError(f"{source}: input.color_order must be one of {COLOR_ORDERS}")
        n = 1 if order == "GRAY" else 3
        spec = InputSpec(
            name=str(raw_in["name"]),
            width=int(raw_in["width"]),
            height=int(raw_in["height"]),
            color_order=order,
            mean=_floats(raw_in.get("mean", [0.0] * n), "input.mean", n, source),
            std=_floats(raw_in.get("std", [1.0] * n), "input.std", n, source),
        )
        outputs = tuple(
            OutputSpec(
                name=str(o["name"]),
                kind=str(o.get("kind", "logits")),
                parent=str(o.get("parent", "") or ""),
                classes=tuple(str(c) for c in o.get("classes", ())),
            )
            for o in data["outputs"]
        )
        card = ModelCard(
            name=str(data.get("name", Path(source).name.removesuffix(CARD_SUFFIX))),
            task=task,
            input=spec,
            outputs=outputs,
            sha256=str(data.get("sha256", "") or ""),
            parameters=int(data.get("parameters", 0) or 0),
            description=str(data.get("description", "") or ""),
            training=dict(data.get("training") or {}),
            metrics=dict(data.get("metrics") or {}),
            ms_per_frame=dict(data.get("ms_per_frame") or {}),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise ModelError(f"{source}: invalid model card: {err!r}") from err
    _validate(card, source)
    return card


def _validate(card: ModelCard, source: str) -> None:
    if card.task not in TASKS:
        raise ModelError(f"{source}: task must be one of {TASKS}, got {card.task!r}")
    if card.input.width <= 0 or card.input.height <= 0:
        raise ModelError(f"{source}: input size must be positive")
    if not card.outputs:
        raise ModelError(f"{source}: the card lists no outputs")
    if card.task == "corridor":
        if card.outputs[0].kind != "probability":
            raise ModelError(f"{source}: a corridor model's first output must be a probability")
        return
    problems = validate_heads(card.heads())
    if problems:
        raise ModelError(f"{source}: bad segmentation heads: " + "; ".join(problems))


def load_card(path: str | os.PathLike[str]) -> ModelCard:
    """Read and validate a model card YAML file.

    Raises:
        ModelError: If the file is missing, unreadable or invalid.
    """
    card_path = Path(path)
    if not card_path.exists():
        raise ModelError(f"model card not found: {card_path}")
    try:
        data = load_document(card_path, "model card", ".yaml")
    except ConfigError as err:
        raise ModelError(str(err)) from err
    return card_from_dict(data, str(card_path))


def write_card(card: ModelCard, path: str | os.PathLike[str]) -> Path:
    """Write ``card`` as YAML to ``path`` atomically and return the path."""
    return write_text_atomic(path, card.to_yaml())


def verify_sha256(card: ModelCard, model_path: str | os.PathLike[str]) -> str:
    """Return the model file's sha256 after checking it against the card.

    Raises:
        ModelError: If the card has no sha256 or it differs from the file's.
    """
    digest = file_sha256(model_path)
    if not card.sha256:
        raise ModelError(f"model card of {model_path} has no sha256; refusing an unverified model")
    if digest != card.sha256:
        raise ModelError(
            f"{model_path} does not match its card: sha256 {digest[:12]}... "
            f"!= {card.sha256[:12]}... (retrained or edited model? rewrite the card)"
        )
    return digest


class _TensorInfo(Protocol):
    @property
    def name(self) -> str: ...
    @property
    def shape(self) -> Sequence[int | str | None]: ...


class SessionLike(Protocol):
    """The part of ``onnxruntime.InferenceSession`` the card check reads."""

    def get_inputs(self) -> Sequence[_TensorInfo]: ...  # noqa: D102
    def get_outputs(self) -> Sequence[_TensorInfo]: ...  # noqa: D102


def check_session(card: ModelCard, session: SessionLike, source: str) -> None:
    """Check a loaded session's input and output names and shapes against the card.

    Raises:
        ModelError: On any mismatch (names, input shape, head channel counts).
    """
    inputs = session.get_inputs()
    if len(inputs) != 1 or inputs[0].name != card.input.name:
        names = [i.name for i in inputs]
        raise ModelError(f"{source}: model inputs {names} != card input [{card.input.name!r}]")
    got = tuple(inputs[0].shape)
    if len(got) != 4 or any(
        isinstance(g, int) and g != want for g, want in zip(got, card.input.shape, strict=True)
    ):
        raise ModelError(f"{source}: model input shape {got} != card {card.input.shape}")
    outputs = {o.name: tuple(o.shape) for o in session.get_outputs()}
    for spec in card.outputs:
        if spec.name not in outputs:
            raise ModelError(
                f"{source}: card output {spec.name!r} is not a model output ({sorted(outputs)})"
            )
        shape = outputs[spec.name]
        want = len(spec.classes) if spec.kind == "logits" else 1
        if len(shape) != 4 or (isinstance(shape[1], int) and shape[1] != want):
            raise ModelError(
                f"{source}: output {spec.name!r} has shape {shape}, card expects {want} channels"
            )
