"""Lane colour from the camera image when the masks carry no level-4 marking classes."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
from typer.testing import CliRunner

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.cli.app import app
from superlane_tools.lanes.attributes import CODE_OF, colour_codes_from_image

CAM = CameraModel(Intrinsics(640, 360, 500.0, 500.0, 319.5, 179.5), Extrinsics(1.5, 0.06))
YELLOW, WHITE = (30, 200, 230), (235, 235, 235)  # BGR paint colours


def _scene(tmp_path):
    """A mask with coarse ids (road 1, lane marking 2) and an image with yellow/white paint."""
    mask = np.zeros((CAM.height, CAM.width), np.uint8)
    image = np.full((CAM.height, CAM.width, 3), 90, np.uint8)
    x = np.linspace(5.0, 60.0, 400)
    road = [CAM.project(np.stack([x, np.full_like(x, y), 0 * x], 1))[0] for y in (6.0, -6.0)]
    poly = np.concatenate([road[0], road[1][::-1]]).round().astype(np.int32)
    cv2.fillPoly(mask, [poly], 1)
    for y, colour in ((1.8, YELLOW), (-1.8, WHITE), (-5.4, WHITE)):
        uv = CAM.project(np.stack([x, np.full_like(x, y), 0 * x], 1))[0].round().astype(np.int32)
        cv2.polylines(mask, [uv], False, 2, 3)
        cv2.polylines(image, [uv], False, colour, 3)
    (tmp_path / "seg").mkdir()
    (tmp_path / "img").mkdir()
    cv2.imwrite(str(tmp_path / "seg" / "f0.png"), mask)
    cv2.imwrite(str(tmp_path / "img" / "f0.jpg"), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    (tmp_path / "seg" / "classes.yaml").write_text("road: [1]\nlane_marking: [2]\n")
    (tmp_path / "cam.yaml").write_text(__import__("yaml").safe_dump(CAM.to_dict()))


def test_colour_codes_from_pixels():
    img = np.zeros((2, 2, 3), np.uint8)
    img[0, 0], img[0, 1] = YELLOW, WHITE
    codes = colour_codes_from_image(img, np.array([[0.0, 0.0], [1.0, 0.0]]))
    assert codes.tolist() == [CODE_OF["yellow_marking"], CODE_OF["white_marking"]]


def test_lanes_fit_reads_colour_from_images(tmp_path):
    _scene(tmp_path)
    args = ["lanes", "fit", str(tmp_path / "seg"), "--camera", str(tmp_path / "cam.yaml")]
    with_images = [*args, "--out", str(tmp_path / "a.parquet"), "--images", str(tmp_path / "img")]
    without = [*args, "--out", str(tmp_path / "b.parquet")]
    for argv in (with_images, without):
        res = CliRunner().invoke(app, argv)
        assert res.exit_code == 0, res.output
    row = pd.read_parquet(tmp_path / "a.parquet").iloc[0]
    by_offset = dict(zip(np.round(row["offsets"]).tolist(), row["colours"], strict=True))
    assert by_offset == {2.0: "yellow", -2.0: "white", -5.0: "white"}
    assert set(pd.read_parquet(tmp_path / "b.parquet").iloc[0]["colours"]) == {"unknown"}
