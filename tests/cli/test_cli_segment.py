"""Tests of `slt segment` through CliRunner on real files."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import typer
import yaml
from typer.testing import CliRunner

from superlane_tools.cli.segment import register
from superlane_tools.hierarchy import leaf_ids_under


def _app() -> typer.Typer:
    app = typer.Typer()

    @app.callback()
    def _root() -> None:
        """Test root."""

    register(app)
    return app


def _folder(tmp_path: Path) -> Path:
    folder = tmp_path / "in"
    (folder / "sub").mkdir(parents=True)
    rng = np.random.default_rng(1)
    img = rng.integers(60, 120, (120, 200, 3), dtype=np.uint8)
    img[60:, 95:100] = 240  # a bright stripe
    cv2.imwrite(str(folder / "a.png"), img)
    cv2.imwrite(str(folder / "sub" / "b.jpg"), img)
    (folder / "broken.png").write_bytes(b"not a png at all")
    (folder / "notes.txt").write_text("ignored")
    return folder


def test_segment_folder_with_one_unreadable_image(tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    out = tmp_path / "out"
    result = CliRunner().invoke(_app(), ["segment", str(folder), "--out", str(out), "--overlay"])
    assert result.exit_code == 3, result.output
    assert "broken.png" in result.output
    for rel in ("a.png", "sub/b.png"):
        labels = cv2.imread(str(out / rel), cv2.IMREAD_UNCHANGED)
        assert labels.shape == (120, 200)
        assert labels.dtype == np.uint8
        assert labels.max() <= 19
    assert (out / "overlays" / "a.jpg").is_file()
    assert (out / "overlays" / "sub" / "b.jpg").is_file()
    assert not (out / "broken.png").exists()
    classes = yaml.safe_load((out / "classes.yaml").read_text())
    assert classes["road"] == [9]
    assert classes["lane_marking"] == list(leaf_ids_under("lane_marking"))
    assert classes["dividing_white_solid"] == [13]
    assert classes["sky"] == [1]


def test_segment_refuses_bad_requests(tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    runner, app = CliRunner(), _app()
    not_a_folder = runner.invoke(
        app, ["segment", str(folder / "a.png"), "--out", str(tmp_path / "o")]
    )
    assert not_a_folder.exit_code == 1  # a file is read as a recording
    assert "not a recording" in not_a_folder.output
    onnx = runner.invoke(
        app,
        [
            "segment",
            str(folder),
            "--out",
            str(tmp_path / "o"),
            "--backend",
            "onnx",
            "--model",
            "missing.onnx",
        ],
    )
    assert onnx.exit_code in {1, 2}
    assert "Traceback" not in onnx.output
    assert "onnx" in onnx.output
    same = runner.invoke(app, ["segment", str(folder), "--out", str(folder)])
    assert same.exit_code == 2
    bad_cam = runner.invoke(
        app, ["segment", str(folder), "--out", str(tmp_path / "o"), "--camera", "nope"]
    )
    assert bad_cam.exit_code == 2  # a bad option value is a usage error
    assert "nope" in bad_cam.output
    assert "Traceback" not in bad_cam.output


def test_segment_real_frames_with_camera(tmp_path: Path, realdata: Path) -> None:
    folder = tmp_path / "frames"
    folder.mkdir()
    shutil.copy(realdata / "tusimple" / "frames" / "0000.png", folder / "0000.png")
    out = tmp_path / "seg"
    result = CliRunner().invoke(
        _app(), ["segment", str(folder), "--out", str(out), "--camera", "tusimple"]
    )
    assert result.exit_code == 0, result.output
    labels = cv2.imread(str(out / "0000.png"), cv2.IMREAD_UNCHANGED)
    assert np.isin(labels, leaf_ids_under("lane_marking")).sum() > 1000
    assert labels[700, 640] == 9
