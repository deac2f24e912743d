"""Resume with more steps or a longer budget, the timed atomic checkpoint, best-on-worst weights
and the best worst margin over a reference model."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest
import torch

from superlane_tools.training.checkpoint import load_checkpoint
from superlane_tools.training.schedule import Schedule
from superlane_tools.training.train import TrainParams, cpu_cores, train
from superlane_tools.training.validation import onnx_segmenter, real_dev_sets, score_sets

REALDATA = Path(os.environ.get("SLT_REALDATA", Path(__file__).parents[3] / "shared" / "data"))


def _params(
    tiny_params: Callable[..., TrainParams], data: Path, out: Path, steps: int
) -> TrainParams:
    return replace(tiny_params("segmentation", data, out), steps=steps, threads=1)


def _dev_folder(tmp_path: Path, camvid: bool = True) -> Path:
    """A real-data folder with the CULane night dev set (and CamVid): quick to validate on."""
    night = REALDATA / "culane" / "nightblur_0531_2336_0004"
    if not night.is_dir():
        pytest.skip("needs the real data")
    dev = tmp_path / "dev"
    (dev / "culane").mkdir(parents=True)
    (dev / "culane" / night.name).symlink_to(night)
    if camvid:
        (dev / "camvid").symlink_to(REALDATA / "camvid")
    return dev


def test_threads_default_to_the_cores(toy_data: Path, tmp_path: Path) -> None:
    params = TrainParams("segmentation", toy_data, tmp_path / "m.onnx")
    assert params.threads == cpu_cores() == len(os.sched_getaffinity(0))


def test_resume_with_more_steps_continues_the_run(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    notes: list[str] = []
    first = train(_params(tiny_params, toy_data, tmp_path / "m.onnx", 6))
    ckpt = tmp_path / "m.ckpt.pt"
    assert load_checkpoint(ckpt, "test")["step"] == 6
    more = train(replace(_params(tiny_params, toy_data, tmp_path / "m.onnx", 12), resume=True),
                 note=notes.append)  # fmt: skip
    assert len(more.step_losses) == 12
    assert more.step_losses[:6] == first.step_losses  # the first six came from the checkpoint
    assert load_checkpoint(ckpt, "test")["step"] == 12
    assert any("resumed" in n and "step 6 of 12" in n for n in notes)
    assert more.card.training["steps"] == 12
    assert math.isfinite(more.seconds_per_step)
    assert more.seconds_per_step > 0


def test_resume_with_a_longer_budget(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    out = tmp_path / "b.onnx"
    base = replace(_params(tiny_params, toy_data, out, 10**6), budget_s=1e-6)
    first = train(base)
    assert len(first.step_losses) == 1  # the budget is spent after one step
    state = load_checkpoint(tmp_path / "b.ckpt.pt", "test")
    assert state["elapsed_s"] > 0
    longer = train(replace(base, budget_s=state["elapsed_s"] + 3600, steps=4, resume=True))
    assert len(longer.step_losses) == 4
    assert longer.step_losses[0] == first.step_losses[0]


def test_schedule_is_rebuilt_from_the_new_total() -> None:
    short, long = Schedule(6, None), Schedule(12, None)
    assert short.spent(6)
    assert not long.spent(6)
    assert long.lr_factor(6) > short.lr_factor(6)  # halfway, not at the end
    budget = Schedule(10**9, 100.0)
    budget.start(elapsed_before_s=99.9999)
    assert budget.elapsed() >= 99.9999
    budget.start(elapsed_before_s=100.0)
    assert budget.spent(0)


def test_checkpoint_is_written_atomically_on_the_time_interval(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    ckpt = tmp_path / "checkpoints" / "run.ckpt.pt"
    params = replace(
        _params(tiny_params, toy_data, tmp_path / "m.onnx", 3),
        checkpoint=ckpt,
        checkpoint_every=0,  # by time only (and at the end)
        checkpoint_s=1e-9,
    )
    steps_seen: list[int] = []

    def progress(step: int, total: int, loss: float) -> None:
        if step >= 2:  # written after step 1 by the interval, before the end
            steps_seen.append(int(load_checkpoint(ckpt, "test")["step"]))

    train(params, progress)
    assert steps_seen[0] == 1
    assert load_checkpoint(ckpt, "test")["step"] == 3
    assert sorted(p.name for p in ckpt.parent.iterdir()) == ["run.ckpt.pt"]  # no temp left


def test_lite0_checkpoint_fits_one_commit(tmp_path: Path) -> None:
    from superlane_tools.training.checkpoint import save_checkpoint
    from superlane_tools.training.lite_seg_net import LiteHierarchicalSegNet

    net = LiteHierarchicalSegNet()
    optimizer = torch.optim.Adam(p for p in net.parameters() if p.requires_grad)
    net(torch.zeros(2, 3, 64, 96))[0].sum().backward()
    optimizer.step()  # Adam's two moments now exist
    state = {"model": net.state_dict(), "optimizer": optimizer.state_dict(), "step": 1}
    path = save_checkpoint(tmp_path / "lite0.ckpt.pt", state)
    assert path.stat().st_size < 40e6  # one file a plain git commit takes


@pytest.mark.skipif(not (REALDATA / "culane").is_dir(), reason="needs the real data")
def test_best_on_worst_weights_are_kept_and_exported(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    dev = _dev_folder(tmp_path)  # two of the real dev sets (all four take longer, same code)
    params = replace(
        _params(tiny_params, toy_data, tmp_path / "v.onnx", 4),
        lr=5e-2,
        validate_every=2,
        val_data=dev,
    )
    notes: list[str] = []
    result = train(params, note=notes.append)
    validation = result.validation
    assert validation is not None
    history = validation["history"]
    assert [h["step"] for h in history] == [2, 4]
    assert set(history[0]["scores"]) == {"culane_night", "camvid_val"}
    best = validation["best"]
    assert best["worst"] == max(h["worst"] for h in history)
    assert best == max(history, key=lambda h: h["worst"])
    assert result.card.training["validation"]["best"]["step"] == best["step"]
    # the kept weights score what was recorded for them, on the same sets
    kept = load_checkpoint(params.best_path, "test")
    from superlane_tools.training.loop import exported_module
    from superlane_tools.training.seg_net import HierarchicalSegNet
    from superlane_tools.training.train import _input_spec, _normalisation

    net = HierarchicalSegNet()
    net.load_state_dict(kept["model"])
    net.eval()
    spec = _input_spec("segmentation", (64, 32), _normalisation(params))
    again = score_sets(onnx_segmenter(exported_module(net), spec, tmp_path), real_dev_sets(dev))
    assert again == best["scores"]


@pytest.mark.skipif(not (REALDATA / "culane").is_dir(), reason="needs the real data")
def test_against_a_reference_the_best_worst_margin_is_kept(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    from superlane_tools.training.validation import reference_scores

    dev = _dev_folder(tmp_path)
    params = replace(
        _params(tiny_params, toy_data, tmp_path / "v.onnx", 6),
        lr=5e-2,
        validate_every=2,
        val_data=dev,
        validate_against="super_seg_v4",
    )
    notes: list[str] = []
    result = train(params, note=notes.append)
    validation = result.validation
    assert validation is not None
    reference = reference_scores("super_seg_v4", real_dev_sets(dev))
    assert validation["reference"] == {"model": "super_seg_v4", "scores": reference}
    assert "worst margin over super_seg_v4" in validation["rule"]
    history = validation["history"]
    assert [h["step"] for h in history] == [2, 4, 6]
    for h in history:  # per set the score minus the reference's, the smallest one
        margins = [h["scores"][k] - reference[k] for k in reference]
        assert h["worst_margin"] == pytest.approx(min(margins), abs=1e-4)
    best = validation["best"]
    assert best == max(history, key=lambda h: h["worst_margin"])
    assert any("worst margin" in n for n in notes)
    kept = load_checkpoint(params.best_path, "test")
    assert json.loads(kept["validation"])["step"] == best["step"]


def test_resume_keeps_the_entry_stored_with_the_kept_weights(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    """A resumed run may select by another rule: the weights on disk decide which entry is best."""
    from superlane_tools.training.checkpoint import save_checkpoint
    from superlane_tools.training.loop import _validator
    from superlane_tools.training.validation import PROTOCOL

    dev = _dev_folder(tmp_path, camvid=False)
    params = replace(_params(tiny_params, toy_data, tmp_path / "v.onnx", 4), validate_every=2)
    params = replace(params, val_data=dev)
    kept = {"protocol": PROTOCOL, "step": 300, "scores": {"culane_night": 0.4}, "worst": 0.4}
    later = {**kept, "step": 600, "scores": {"culane_night": 0.9}, "worst": 0.9}
    params.best_path.parent.mkdir(parents=True, exist_ok=True)
    save_checkpoint(params.best_path, {"model": {}, "validation": json.dumps(kept)})
    validator = _validator(params, [kept, later])
    assert validator is not None
    assert validator.best == kept  # not the history's maximum: those weights are not on disk


@pytest.mark.skipif(not (REALDATA / "culane").is_dir(), reason="needs the real data")
def test_every_real_dev_set_loads_with_its_labels() -> None:
    sets = {s.name: s for s in real_dev_sets(REALDATA)}
    assert set(sets) == {"tusimple_dev", "culane_day_dev", "culane_night", "camvid_val"}
    assert len(sets["tusimple_dev"].images) == 36
    assert len(sets["culane_day_dev"].images) == 60  # the held-out clip, never the driver-23 one
    assert sum(len(lanes) for lanes in sets["culane_day_dev"].lanes) > 100
    assert all(img.shape[1] == 640 for img in sets["culane_night"].images)


@pytest.mark.skipif(not (REALDATA / "culane").is_dir(), reason="needs the real data")
def test_culane_dev_sets_are_validated_in_a_camera_estimated_from_their_frames() -> None:
    from superlane_tools.camera.model import CameraModel

    sets = {s.name: s for s in real_dev_sets(REALDATA)}
    assert sets["tusimple_dev"].camera == "tusimple"  # its profile
    assert sets["camvid_val"].camera == ""  # no lanes, camera unknown: as it is
    for name in ("culane_day_dev", "culane_night"):
        camera = sets[name].camera
        assert isinstance(camera, CameraModel), name
        assert camera.intrinsics.width == 640  # the dev frames' width
        assert 0.5 < camera.extrinsics.height_m < 3.5
        assert abs(math.degrees(camera.extrinsics.pitch_rad)) < 10


def test_a_resumed_run_drops_validations_of_another_protocol(
    toy_data: Path, tiny_params: Callable[..., TrainParams], tmp_path: Path
) -> None:
    from superlane_tools.training.loop import _validator
    from superlane_tools.training.validation import PROTOCOL

    dev = _dev_folder(tmp_path, camvid=False)  # one small real set is enough to build the validator
    params = replace(_params(tiny_params, toy_data, tmp_path / "v.onnx", 4), validate_every=2)
    params = replace(params, val_data=dev)
    params.best_path.parent.mkdir(parents=True, exist_ok=True)
    params.best_path.write_bytes(b"kept weights")
    old = {"step": 300, "scores": {"culane_night": 0.9}, "worst_set": "culane_night", "worst": 0.9}
    new = {**old, "protocol": PROTOCOL, "step": 600, "worst": 0.4}
    stale = _validator(params, [old])
    assert stale is not None
    assert stale.history == []
    assert stale.best is None
    kept = _validator(params, [old, new])
    assert kept is not None
    assert kept.history == [new]
    assert kept.best == new
