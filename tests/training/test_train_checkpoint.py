"""Checkpoints load weights-only: a normal one fine-tunes and resumes, one with code is refused."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest
import torch

from superlane_tools.training import TrainingError
from superlane_tools.training.checkpoint import load_checkpoint
from superlane_tools.training.train import TrainParams, TrainResult, train


class Payload:
    """A checkpoint entry that runs a shell command when unpickled (what an attacker ships)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str]]:
        return (os.system, (f"touch {self.marker}",))


class Extra:
    """A harmless custom class: still more than weights, so still refused."""

    def __init__(self) -> None:
        self.note = "custom"


def _ckpt(result: TrainResult) -> Path:
    return result.model_path.with_name(result.model_path.stem + ".ckpt.pt")


def _malicious(real: Path, out: Path, marker: Path) -> Path:
    state = torch.load(real, weights_only=True)  # a real checkpoint, plus code
    state["extra"] = Extra()
    state["payload"] = Payload(marker)
    torch.save(state, out)
    return out


@pytest.mark.slow
def test_normal_checkpoint_inits_and_resumes(
    tiny_seg: TrainResult,
    toy_data: Path,
    tiny_params: Callable[[str, Path, Path], TrainParams],
    tmp_path: Path,
) -> None:
    ckpt = _ckpt(tiny_seg)
    state = load_checkpoint(ckpt, "test")
    assert set(state) >= {"model", "optimizer", "generator", "losses", "step", "elapsed_s"}
    tuned = train(replace(tiny_params("segmentation", toy_data, tmp_path / "ft.onnx"), init=ckpt))
    assert len(tuned.step_losses) == 4
    shutil.copy(ckpt, tmp_path / "res.ckpt.pt")
    resumed = train(
        replace(tiny_params("segmentation", toy_data, tmp_path / "res.onnx"), resume=True)
    )
    assert resumed.step_losses == tiny_seg.step_losses  # all 4 steps came from the checkpoint


@pytest.mark.parametrize("how", ["init", "resume"])
def test_checkpoint_with_code_is_refused(
    tiny_seg: TrainResult,
    toy_data: Path,
    tiny_params: Callable[[str, Path, Path], TrainParams],
    tmp_path: Path,
    how: str,
) -> None:
    marker = tmp_path / "pwned"
    out = tmp_path / "m.onnx"
    evil = _malicious(_ckpt(tiny_seg), tmp_path / "m.ckpt.pt", marker)
    params = tiny_params("segmentation", toy_data, out)
    params = replace(params, init=evil) if how == "init" else replace(params, resume=True)
    with pytest.raises(TrainingError, match="refused: the checkpoint holds objects") as info:
        train(params)
    assert "Payload" in str(info.value) or "system" in str(info.value)
    assert not marker.exists()
    assert not out.exists()


@pytest.mark.slow
def test_cli_refuses_checkpoint_with_code(
    tiny_seg: TrainResult, toy_data: Path, tmp_path: Path
) -> None:
    marker = tmp_path / "pwned"
    evil = _malicious(_ckpt(tiny_seg), tmp_path / "evil.pt", marker)
    damaged = tmp_path / "damaged.pt"
    damaged.write_bytes(_ckpt(tiny_seg).read_bytes()[:5000])
    slt = [sys.executable, "-c", "from superlane_tools.cli.app import main; main()"]
    args = ["train", "segmentation", "--out", str(tmp_path / "m.onnx"), "--data", str(toy_data)]
    args += ["--steps", "1", "--batch", "2", "--size", "64x32"]
    for ckpt, match, code in ((evil, "refused", 1), (damaged, "cannot read checkpoint", 1)):
        res = subprocess.run(
            [*slt, *args, "--init", str(ckpt)],
            capture_output=True,
            text=True,
            check=False,
        )
        assert res.returncode == code, res.stderr
        lines = [ln for ln in res.stderr.splitlines() if ln.startswith("slt: error:")]
        assert len(lines) == 1, res.stderr
        assert match in lines[0]
        assert "Traceback" not in res.stderr
    assert not marker.exists()
