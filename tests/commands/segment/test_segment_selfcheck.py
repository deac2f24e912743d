"""``slt segment``: ``auto`` on an image folder chooses the backend by the self-check."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app

runner = CliRunner()


@pytest.mark.slow
def test_slt_segment_runs_the_self_check_on_an_image_folder(realdata: Path, tmp_path: Path) -> None:
    import shutil

    folder = tmp_path / "images"
    folder.mkdir()
    source = realdata / "tusimple" / "train_frames" / "images"
    for path in sorted(source.glob("*.jpg"))[:12]:
        shutil.copy(path, folder / path.name)
    out = tmp_path / "labels"
    result = runner.invoke(app, ["segment", str(folder), "--out", str(out), "--camera", "tusimple"])
    assert result.exit_code == 0, result.stderr
    assert "slt: note: segmentation self-check on 12 frames" in result.stderr
    assert "most plausible lanes" in result.stderr
    assert len(list(out.glob("*.png"))) >= 12
    plain = runner.invoke(app, ["segment", str(folder), "--out", str(tmp_path / "plain")])
    assert plain.exit_code == 0, plain.stderr
    assert "self-check skipped: it fits lanes in metres and needs the camera" in plain.stderr


def test_canonical_camera_runs_a_plain_network_in_it(realdata: Path, tmp_path: Path) -> None:
    """``--canonical-camera`` resamples for v4 too; the labels stay in the images' pixels."""
    import cv2
    import numpy as np

    folder = realdata / "tusimple" / "frames"
    base = ["segment", str(folder), "--model", "super_seg_v4", "--camera", "tusimple"]
    plain = runner.invoke(app, [*base, "--out", str(tmp_path / "plain")])
    canon = runner.invoke(app, [*base, "--out", str(tmp_path / "canon"), "--canonical-camera"])
    assert plain.exit_code == 0, plain.stderr
    assert canon.exit_code == 0, canon.stderr
    assert "with the onnx:super_seg_v4 backend" in plain.stderr
    assert "with the onnx:super_seg_v4+canonical backend" in canon.stderr
    name = sorted(p.name for p in (tmp_path / "plain").glob("*.png"))[0]
    a = cv2.imread(str(tmp_path / "plain" / name), cv2.IMREAD_UNCHANGED)
    b = cv2.imread(str(tmp_path / "canon" / name), cv2.IMREAD_UNCHANGED)
    assert a.shape == b.shape  # the recording's own pixels either way
    assert not np.array_equal(a, b)  # but seen through another camera
    no_camera = runner.invoke(
        app, ["segment", str(folder), "--model", "super_seg_v4", "--canonical-camera",
              "--out", str(tmp_path / "none")],
    )  # fmt: skip
    assert no_camera.exit_code != 0
    assert "give the images' camera" in no_camera.stderr
