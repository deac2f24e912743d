"""`pipelines/train_models.py --recipe canonical`: its command line and its datasets list."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from superlane_tools.training.datasets import load_dataset_list

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "pipelines"))

import importlib.util  # noqa: E402

_SPEC = importlib.util.spec_from_file_location("train_models", REPO / "pipelines/train_models.py")
assert _SPEC is not None
assert _SPEC.loader is not None
tm = importlib.util.module_from_spec(_SPEC)
sys.modules["train_models"] = tm
_SPEC.loader.exec_module(tm)


def _values(args: list[str], flag: str) -> str:
    return args[args.index(flag) + 1]


def test_canonical_list_trains_driver_23_never_driver_161(tmp_path: Path) -> None:
    realdata = tmp_path / "data"
    camera = tmp_path / "culane_day_train.yaml"
    listing = tm.canonical_list(realdata, tmp_path / "sim", tmp_path, True, camera)
    text = listing.read_text(encoding="utf-8")
    assert "driver_23_05151649_0422" in text
    assert "driver_161" not in text
    specs = {s.reader: s for s in load_dataset_list(listing)}
    assert set(specs) == {"tusimple", "culane", "camvid", "sim"}
    assert specs["culane"].camera == str(camera)
    assert specs["culane"].folder == realdata.resolve() / tm.CULANE_TRAIN
    # TuSimple's train split: the dev frames real_frames_eval holds out are left out
    assert specs["tusimple"].split == "train"
    assert specs["tusimple"].folder == realdata.resolve() / "tusimple" / "train_frames"
    nc = load_dataset_list(tm.canonical_list(realdata, tmp_path / "sim", tmp_path, False, None))
    assert [s.reader for s in nc] == ["tusimple", "sim"]
    assert "driver_161" in tm.CULANE_HELD_OUT


def test_canonical_command_line(tmp_path: Path) -> None:
    ckpt = REPO / "checkpoints" / "super_seg_v6.ckpt.pt"
    args = tm.canonical_command(
        tmp_path / "d.yaml", tmp_path / "super_seg_v6.onnx", tm.FULL, "cpu", 7200.0, 6000, ckpt,
        (tmp_path, 250),
    )  # fmt: skip
    assert args[:2] == ["train", "segmentation"]
    assert _values(args, "--arch") == "lite0-s16"
    assert _values(args, "--size") == "512x160"
    assert "--canonical-camera" in args
    assert _values(args, "--augment") == "canonical"
    assert "--crop" not in args
    assert _values(args, "--threads") == str(os.cpu_count())
    assert _values(args, "--checkpoint") == str(ckpt)
    assert "--resume" in args
    assert _values(args, "--budget-s") == "7200"
    assert _values(args, "--steps") == "6000"
    assert _values(args, "--val-data") == str(tmp_path.resolve())
    assert _values(args, "--validate-every") == "250"
    assert _values(args, "--validate-against") == "super_seg_v4"  # the shipped default to beat
    quiet = tm.canonical_command(
        tmp_path / "d.yaml", tmp_path / "m.onnx", tm.QUICK, "cpu", 60.0, 2, ckpt, (None, 300)
    )
    assert "--val-data" not in quiet
    assert "--validate-against" not in quiet
    assert _values(quiet, "--max-frames") == "2"


def test_near_recipe_fine_tunes_the_canonical_checkpoint_at_the_taller_band(
    tmp_path: Path,
) -> None:
    ckpt = tmp_path / "super_seg_v6.ckpt.pt"
    canonical = tm.canonical_command(
        tmp_path / "d.yaml", tmp_path / "super_seg_v6.onnx", tm.FULL, "cpu", 3000.0, 6000, ckpt,
        (tmp_path, 300),
    )  # fmt: skip
    out, near_ckpt = tmp_path / "super_seg_v7.onnx", tmp_path / "super_seg_v7.ckpt.pt"
    args = tm.near_command(canonical, out, near_ckpt, ckpt)
    assert _values(args, "--size") == "512x224"
    assert _values(args, "--canonical-near-m") == "3.4"
    assert _values(args, "--lr") == "0.001"
    assert _values(args, "--init") == str(ckpt)  # from the canonical model's weights
    assert _values(args, "--checkpoint") == str(near_ckpt)  # its own checkpoint
    assert _values(args, "--out") == str(out)
    assert _values(args, "--validate-against") == "super_seg_v4"
    assert _values(args, "--datasets") == _values(canonical, "--datasets")
    assert canonical[canonical.index("--size") + 1] == "512x160"  # not changed in place


def test_half_recipe_fine_tunes_the_near_checkpoint_with_heads_at_half(tmp_path: Path) -> None:
    ckpt = tmp_path / "super_seg_v6.ckpt.pt"
    canonical = tm.canonical_command(
        tmp_path / "d.yaml", tmp_path / "super_seg_v6.onnx", tm.FULL, "cpu", 4800.0, 6000, ckpt,
        (tmp_path, 300),
    )  # fmt: skip
    near_ckpt = tmp_path / "super_seg_v7.ckpt.pt"
    near = tm.near_command(canonical, tmp_path / "super_seg_v7.onnx", near_ckpt, ckpt)
    out, half_ckpt = tmp_path / "super_seg_v8.onnx", tmp_path / "super_seg_v8.ckpt.pt"
    args = tm.half_command(near, out, half_ckpt, near_ckpt)
    assert _values(args, "--arch") == "lite0-s16-half"
    assert _values(args, "--init") == str(near_ckpt)  # from the near model's weights
    assert _values(args, "--checkpoint") == str(half_ckpt)
    assert _values(args, "--out") == str(out)
    for flag in ("--size", "--canonical-near-m", "--lr", "--datasets", "--validate-against"):
        assert _values(args, flag) == _values(near, flag)  # the near recipe otherwise
    assert _values(near, "--arch") == "lite0-s16"  # not changed in place


def test_recipe_command_parses_through_slt_train(tmp_path: Path) -> None:
    """The CLI accepts every option the recipe passes (an unknown one would exit 2)."""
    from typer.testing import CliRunner

    from superlane_tools.cli.app import app

    args = tm.canonical_command(
        tmp_path / "missing.yaml", tmp_path / "m.onnx", tm.QUICK, "cpu", 60.0, 2,
        tmp_path / "m.ckpt.pt", (tmp_path, 300),
    )  # fmt: skip
    assert "--validate-against" in args
    result = CliRunner().invoke(app, args)
    assert result.exit_code != 2, result.output
    assert "missing.yaml" in result.output
    near = tm.near_command(
        args, tmp_path / "n.onnx", tmp_path / "n.ckpt.pt", tmp_path / "m.ckpt.pt"
    )
    result = CliRunner().invoke(app, near)
    assert result.exit_code != 2, result.output
    assert "missing.yaml" in result.output
    half = tm.half_command(
        near, tmp_path / "h.onnx", tmp_path / "h.ckpt.pt", tmp_path / "n.ckpt.pt"
    )
    result = CliRunner().invoke(app, half)
    assert result.exit_code != 2, result.output
    assert "missing.yaml" in result.output
