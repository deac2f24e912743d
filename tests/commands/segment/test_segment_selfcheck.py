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
