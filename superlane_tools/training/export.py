"""ONNX export with a torch/onnxruntime agreement check, and the model card written beside it."""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from torch import nn

from superlane_tools.reporting.atomic import atomic_path
from superlane_tools.training.errors import TrainingError

OPSET = 17
MAX_ABS_DIFF = 1e-4


def export_onnx(
    model: nn.Module,
    input_shape: tuple[int, int, int, int],
    path: str | os.PathLike[str],
    input_name: str,
    output_names: Sequence[str],
    seed: int = 0,
) -> float:
    """Export ``model`` (eval mode, static shapes, opset 17) and check onnxruntime agrees.

    Args:
        model: The network; it is switched to eval mode.
        input_shape: Static ``(1, C, H, W)`` input shape.
        path: Target ``.onnx`` path (written atomically).
        input_name: Name of the graph input.
        output_names: Names of the graph outputs, in ``forward`` return order.
        seed: Seed of the random check input.

    Returns:
        The largest absolute difference between torch and onnxruntime outputs on a random input.

    Raises:
        TrainingError: If export fails or the outputs differ by more than ``MAX_ABS_DIFF``.
    """
    import onnxruntime as ort

    model.eval()
    gen = torch.Generator().manual_seed(seed)
    example = torch.randn(*input_shape, generator=gen)
    target = Path(path)
    with atomic_path(target, suffix=".onnx") as tmp:
        try:
            with warnings.catch_warnings():
                # the TorchScript exporter is deprecated in favour of torch.export, which needs
                # onnxscript (not a dependency); the TorchScript path is what static CNNs need
                warnings.simplefilter("ignore", DeprecationWarning)
                warnings.simplefilter("ignore", getattr(torch.jit, "TracerWarning", UserWarning))
                torch.onnx.export(
                    model,
                    (example,),
                    str(tmp),
                    input_names=[input_name],
                    output_names=list(output_names),
                    opset_version=OPSET,
                    do_constant_folding=True,
                    dynamo=False,
                )
        except Exception as err:  # torch.onnx raises many unrelated types
            raise TrainingError(f"ONNX export failed: {err}") from err
        with torch.no_grad():
            ref = model(example)
        refs = ref if isinstance(ref, tuple) else (ref,)
        options = ort.SessionOptions()
        options.log_severity_level = 3
        session = ort.InferenceSession(str(tmp), options, providers=["CPUExecutionProvider"])
        got = session.run(list(output_names), {input_name: example.numpy()})
        diff = max(
            float(np.max(np.abs(np.asarray(a) - b.numpy()))) for a, b in zip(got, refs, strict=True)
        )
        if diff > MAX_ABS_DIFF:
            raise TrainingError(
                f"onnxruntime and torch disagree after export: max |diff| {diff:.2e}"
            )
    return diff
