"""Segmentation backends by name: the factory over the classical and ONNX backends.

Kept apart from :mod:`superlane_tools.scene.backend` (the protocol both backends import), so that
the protocol module never imports a backend.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

from superlane_tools.camera.model import CameraModel
from superlane_tools.scene.backend import SegmentationBackend
from superlane_tools.scene.errors import BackendUnavailableError

BackendFactory = Callable[[str | None, CameraModel | None, bool, int], SegmentationBackend]


def _classical(
    model: str | None, camera: CameraModel | None, canonical: bool = False, threads: int = 2
) -> SegmentationBackend:
    """The classical backend (it works in the images' own camera: ``canonical`` is not for it)."""
    del canonical, threads
    from superlane_tools.scene.classical import ClassicalExtractor

    if model:
        raise BackendUnavailableError(
            "the classical backend takes no model; drop --model or use --backend onnx"
        )
    return ClassicalExtractor(camera=camera)


def _onnx(
    model: str | None, camera: CameraModel | None, canonical: bool = False, threads: int = 2
) -> SegmentationBackend:
    from superlane_tools.scene.canonical_backend import (
        CanonicalBackend,
        canonical_for_card,
        trained_canonical,
    )
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    backend = OnnxSegmentationBackend(model, threads=threads)
    trained = trained_canonical(backend.card)
    if trained is None and not canonical:
        return backend  # the network works in the image; its card fixes the input size
    if camera is None:
        why = "was trained in" if trained is not None else "runs (--canonical-camera) in"
        raise BackendUnavailableError(
            f"{backend.card.name} {why} the canonical camera: give the images' camera "
            "(--camera PROFILE|YAML)"
        )
    return CanonicalBackend(backend, camera, trained or canonical_for_card(backend.card))


def _auto(
    model: str | None, camera: CameraModel | None, canonical: bool = False, threads: int = 2
) -> SegmentationBackend:
    name, _ = auto_backend(model)
    return _FACTORIES[name](model, camera, canonical, threads)


_FACTORIES: dict[str, BackendFactory] = {"auto": _auto, "classical": _classical, "onnx": _onnx}


def known_backends() -> tuple[str, ...]:
    """Return the names accepted by :func:`backend_from_name`, sorted."""
    return tuple(sorted(_FACTORIES))


def backend_from_name(
    name: str,
    *,
    model: str | None = None,
    camera: CameraModel | None = None,
    canonical: bool = False,
    threads: int = 2,
) -> SegmentationBackend:
    """Build the segmentation backend called ``name``.

    Args:
        name: Backend name (see :func:`known_backends`), case-insensitive.
        model: Model file path or shipped model name, for backends that load one.
        camera: Camera of the images, for backends that use geometry (the classical one) and
            for a network run in the canonical camera.
        canonical: Run a network trained without the canonical camera in it too
            (``scene.canonical_backend``; needs ``camera``). A network trained in it always
            runs in it; the classical backend works in the images' own camera.
        threads: onnxruntime intra-op threads of a network (1 where frames already run on a
            pool of threads, as in ``slt reprocess``).

    Raises:
        BackendUnavailableError: If the name is unknown (the message lists the known ones) or
            the backend cannot run here (e.g. no model available).
    """
    factory = _FACTORIES.get(name.strip().lower())
    if factory is None:
        raise BackendUnavailableError(
            f"unknown segmentation backend {name!r} (known: {', '.join(known_backends())})"
        )
    return factory(model, camera, canonical, threads)


REAL_METRIC = "tusimple_val_end_to_end"
"""Card metrics section with the end-to-end LaneEval accuracy on real validation frames."""
REAL_SETS = "real_sets"
"""Card metrics section with the model's and the classical backend's score on every real set."""


def worst_real_set(metrics: dict[str, object]) -> tuple[str, float, str, float] | None:
    """Return ``(set, score)`` of the model's worst real lane set and of the classical backend's.

    The sets are the card's :data:`REAL_SETS` entries with a classical number (TuSimple dev end
    to end, KITTI ego lane, CULane night); None when the card has none.
    """
    sets = metrics.get(REAL_SETS)
    if not isinstance(sets, dict):
        return None
    pairs = {
        name: (float(v["model"]), float(v["classical"]))
        for name, v in sets.items()
        if isinstance(v, dict) and "model" in v and "classical" in v
    }
    if not pairs:
        return None
    model_set = min(pairs, key=lambda n: pairs[n][0])
    classical_set = min(pairs, key=lambda n: pairs[n][1])
    return model_set, pairs[model_set][0], classical_set, pairs[classical_set][1]


def auto_backend(model: str | None) -> tuple[str, str]:
    """Resolve ``auto`` to ``onnx`` or ``classical``; return the name and a note ("" if none).

    An explicit ``model`` means ``onnx``. Otherwise ``auto`` uses the shipped default
    segmentation model when, by its card, its worst real lane set (:func:`worst_real_set`:
    TuSimple dev end to end, KITTI ego lane, CULane night) scores at least the classical
    backend's worst set measured in the same run, and the classical backend otherwise (or when
    no model is shipped). A card without per-set numbers falls back to the TuSimple end-to-end
    LaneEval accuracy (:data:`REAL_METRIC`). ``slt segment`` and ``slt reprocess`` share this
    rule.
    """
    from superlane_tools.errors import SltError
    from superlane_tools.models import list_models
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL, resolve_model

    if model:
        return "onnx", ""
    if DEFAULT_SEGMENTATION_MODEL not in list_models():
        return "classical", (
            f"no shipped segmentation model ({DEFAULT_SEGMENTATION_MODEL}): "
            "fell back to the classical backend"
        )
    try:
        card = load_card(resolve_model(DEFAULT_SEGMENTATION_MODEL)[1])
        worst = worst_real_set(dict(card.metrics))
        real = card.metrics.get(REAL_METRIC) or {}
        acc, classical = real.get("laneeval_accuracy"), real.get("classical_laneeval_accuracy")
    except (SltError, AttributeError) as err:
        return "classical", f"{DEFAULT_SEGMENTATION_MODEL}: unreadable model card ({err})"
    if worst is not None:
        model_set, model_score, classical_set, classical_score = worst
        if model_score >= classical_score:
            return "onnx", ""
        return "classical", (
            f"classical backend: its worst real set ({classical_set} {classical_score:.3f}) is "
            f"better than {card.name}'s ({model_set} {model_score:.3f}) (model card; "
            "--backend onnx forces the model)"
        )
    if acc is None or classical is None:
        return "classical", f"{card.name} has no real-frame accuracy in its card: classical backend"
    if float(acc) >= float(classical):
        return "onnx", ""
    return "classical", (
        f"classical backend: LaneEval {float(classical):.3f} > {card.name} {float(acc):.3f} on "
        "real frames (model card; --backend onnx forces the model)"
    )


def auto_candidates() -> tuple[tuple[str, str], ...]:
    """Return the ``(backend, model)`` pairs ``auto`` chooses among, fastest first.

    Every candidate that could win on a drive: the shipped default segmentation model, the
    newest shipped segmentation model when it is not the default (a model that did not pass the
    default rule, ``scene.default_rule``, may still serve some drives better), ordered by their
    cards' milliseconds per frame, then the classical backend. The per-drive self-check
    (``drive.selfcheck``) tries them in this order on a sample of the drive's frames.
    """
    from superlane_tools.models import list_models
    from superlane_tools.scene.default_rule import model_version
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL

    shipped = list_models()
    seg = [m for m in shipped if m.startswith("super_seg_v")]
    models = [DEFAULT_SEGMENTATION_MODEL] if DEFAULT_SEGMENTATION_MODEL in shipped else []
    newest = max(seg, key=model_version, default="")
    if newest and newest not in models:
        models.append(newest)
    models.sort(key=_card_ms)
    return (*(("onnx", m) for m in models), ("classical", ""))


@cache
def _card_ms(model: str) -> float:
    """Return a shipped model's card milliseconds per frame (inf when unreadable)."""
    from superlane_tools.errors import SltError
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import resolve_model

    try:
        ms = load_card(resolve_model(model)[1]).ms_per_frame
        return float(ms.get("median_ms", "inf"))
    except (SltError, TypeError, ValueError):
        return float("inf")
