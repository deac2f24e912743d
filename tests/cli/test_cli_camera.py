"""`slt camera` commands through Typer's CliRunner."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from superlane_tools.camera import camera_from_yaml, kitti_camera, load_camera
from superlane_tools.cli.app import app

runner = CliRunner()


def test_list_shows_every_bundled_profile() -> None:
    result = runner.invoke(app, ["camera", "list"])
    assert result.exit_code == 0, result.output
    for name in ("kitti", "sim_default", "tusimple"):
        assert name in result.stdout
    assert "1280x720" in result.stdout


def test_show_prints_loadable_yaml_with_derived_values(tmp_path: Path) -> None:
    result = runner.invoke(app, ["camera", "show", "sim_default"])
    assert result.exit_code == 0, result.output
    assert "# horizon row: 299.4 px" in result.stdout
    assert camera_from_yaml(result.stdout) == load_camera("sim_default")
    path = tmp_path / "cam.yaml"
    path.write_text(result.stdout, encoding="utf-8")
    again = runner.invoke(app, ["camera", "show", str(path)])
    assert again.exit_code == 0
    assert again.stdout == result.stdout


def test_show_unknown_profile_is_one_error_line() -> None:
    result = runner.invoke(app, ["camera", "show", "nope"])
    assert result.exit_code == 2  # a bad value, as --camera nope everywhere
    assert result.stderr.startswith("slt: error: camera show: Invalid value for 'CAMERA': ")
    assert "unknown camera profile 'nope'" in result.stderr
    assert result.stderr.count("\n") == 1


def test_from_kitti_prints_and_writes_the_camera(realdata: Path, tmp_path: Path) -> None:
    calib = realdata / "kitti_road" / "calib_um_000000.txt"
    result = runner.invoke(app, ["camera", "from-kitti", str(calib)])
    assert result.exit_code == 0, result.output
    assert camera_from_yaml(result.stdout) == kitti_camera(calib)
    out = tmp_path / "sub" / "kitti.yaml"
    result = runner.invoke(
        app,
        [
            "camera",
            "from-kitti",
            str(calib),
            "--width",
            "621",
            "--height",
            "188",
            "--name",
            "half",
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    cam = load_camera(out)
    assert (cam.width, cam.height, cam.name) == (621, 188, "half")
    assert cam.intrinsics.fx == kitti_camera(calib).intrinsics.fx  # size only, no rescale


def test_from_kitti_bad_input_exits_1(tmp_path: Path) -> None:
    bad = tmp_path / "calib.txt"
    bad.write_text("P2: 1 2 3\n", encoding="utf-8")
    for path in (bad, tmp_path / "missing.txt"):
        result = runner.invoke(app, ["camera", "from-kitti", str(path)])
        assert result.exit_code == 1
        assert result.stderr.startswith("slt: error: ")
        assert "Traceback" not in result.output
