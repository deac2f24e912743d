"""Classical (no network) scene extractor: lane markings by a ridge filter, road, sky.

The extractor produces the same leaf-id label images as a trained segmentation network
(:mod:`superlane_tools.hierarchy`), so it can stand in as a fallback backend and a point of
comparison. Every step is driven by the camera geometry of each image row:

1. **Row geometry.** For each image row below the horizon the flat-ground model gives the forward
   distance (m) and the lateral size of one pixel (m). A painted line of ``marking_width_m``
   then has an expected width in pixels for that row. Without a camera a nominal one is assumed
   (focal length = image width, 1.5 m high, horizon at 40 % of the image height), which makes the
   expected width a linear function of the row.
2. **Lane markings.** A symmetric ridge filter on the brightness ``(R + G) / 2``: a pixel is a
   candidate when it is brighter by at least ``contrast_min`` than *both* pixels
   ``ridge_offset_factor`` expected widths to its left and to its right on the same row (paint is
   brighter than the asphalt on either side; edges of wide bright objects fail one side).
   Yellow pixels get their blue deficit added (``yellow_gain``), so worn yellow paint that is
   barely brighter than the asphalt still stands out. Horizontal runs wider than the plausible
   (slant-tolerant) width are dropped, then connected components that are neither line-like
   (large and elongated) nor dot-like (the size of a Botts' dot or raised reflector of
   ``dot_diameter_m`` at their row). Markings must lie within the road's span.
3. **Colour.** Each marking component is yellow (leaf 15) when most of its pixels have a yellow
   hue and enough saturation in HSV, else white. White components whose ground length is
   shorter than ``dash_max_length_m`` are marked dashed (14), others solid (13); the final
   solid/dashed decision belongs to the lane fit, which sees the whole line.
4. **Road** (leaf 9): in a downscaled image, pixels whose Lab colour is close to that of a patch
   at the bottom centre (robust z-score), connected to that patch, below the horizon; marking
   pixels count as road for connectivity.
5. **Sky** (leaf 1): smooth (low gradient), not green, bright-or-bluish pixels above the horizon
   connected to the top border.

Everything else is void (0). The parameters are physical (metres, grey levels) rather than
tuned per dataset.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.scene.backend import ImageBGR, LabelImage, check_image

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

ROAD = LEAF_IDS["road"]
SKY = LEAF_IDS["sky"]
WHITE_SOLID = LEAF_IDS["dividing_white_solid"]
WHITE_DASHED = LEAF_IDS["dividing_white_dashed"]
YELLOW_SOLID = LEAF_IDS["dividing_yellow_solid"]


@dataclass(frozen=True)
class ClassicalParams:
    """Parameters of the classical extractor (physical units where possible).

    Attributes:
        marking_width_m: Painted line width, metres (US 0.10-0.15, EU 0.12-0.30).
        ridge_offset_factor: Side samples of the ridge filter sit this many expected marking
            widths left and right of the pixel (> 1 so slanted lines are cleared).
        min_offset_px: Smallest side-sample offset, pixels.
        contrast_min: Minimal brightness excess over both sides, grey levels (0-255).
        max_run_factor: Horizontal runs wider than this many expected widths are not paint.
        max_distance_m: Markings farther than this are ignored (rows too compressed near the
            horizon).
        min_component_px: Smallest marking component, pixels.
        min_elongation: Smallest ratio of the major to the minor axis of a marking component.
        dash_max_length_m: White components shorter than this on the ground count as dashes.
        yellow_hue: Hue range of yellow paint, OpenCV units (0-180).
        yellow_min_saturation: Smallest HSV saturation (0-255) of yellow paint.
        road_width_px: Width of the downscaled image used for the road and sky regions.
        road_max_z: Largest robust z-score (Lab distance to the seed patch) of road pixels.
        road_margin_m: Markings may lie this far (one lane, metres) beside the grown road,
            which often misses lanes paved in a different shade.
        sky_max_gradient: Largest Sobel gradient (grey levels per pixel, downscaled) in the sky.
        dot_diameter_m: Diameter of round road dots (Botts' dots, raised reflectors: 0.10 m);
            bright blobs of that size are markings. 0 disables dots.
        dot_size_tolerance: A dot's bounding box may be this factor smaller or larger than
            expected (blur, bloom and the camera's pitch error at far rows).
        yellow_gain: Weight of the blue deficit ``(R + G) / 2 - B - 10`` added to the
            brightness of the ridge filter (0: plain ``(R + G) / 2``).
    """

    marking_width_m: float = 0.15
    ridge_offset_factor: float = 2.0
    min_offset_px: int = 2
    contrast_min: float = 18.0
    max_run_factor: float = 5.0
    max_distance_m: float = 120.0
    min_component_px: int = 12
    min_elongation: float = 2.5
    dash_max_length_m: float = 8.0
    yellow_hue: tuple[int, int] = (15, 40)
    yellow_min_saturation: int = 70
    road_width_px: int = 160
    road_max_z: float = 3.5
    road_margin_m: float = 3.5
    sky_max_gradient: float = 12.0
    dot_diameter_m: float = 0.10
    dot_size_tolerance: float = 3.0
    yellow_gain: float = 1.0


class RowGeometry(NamedTuple):
    """Flat-ground geometry of each image row.

    Attributes:
        distance_m: ``(H,)`` forward distance of the row at the principal column, metres (NaN
            above the horizon).
        metres_per_px: ``(H,)`` lateral ground size of one pixel on the row, metres (NaN above).
        horizon_row: Image row of the horizon (may be fractional or outside the image).
    """

    distance_m: FloatArray
    metres_per_px: FloatArray
    horizon_row: float


def nominal_camera(width: int, height: int) -> CameraModel:
    """Return the camera assumed when none is given.

    Focal length equal to the image width (about 53 degrees horizontal field of view), 1.5 m above
    the road, pitched so that the horizon lies at 40 % of the image height.
    """
    f = float(width)
    cy = (height - 1) / 2.0
    pitch = float(np.arctan((cy - 0.4 * height) / f))
    intr = Intrinsics(width=width, height=height, fx=f, fy=f, cx=(width - 1) / 2.0, cy=cy)
    return CameraModel(intr, Extrinsics(height_m=1.5, pitch_rad=pitch), name="nominal")


def row_geometry(camera: CameraModel) -> RowGeometry:
    """Return the forward distance and lateral pixel size of every row of ``camera``'s image."""
    rows = np.arange(camera.height, dtype=np.float64)
    cx = camera.intrinsics.cx
    uv = np.concatenate(
        [
            np.stack([np.full_like(rows, cx), rows], 1),
            np.stack([np.full_like(rows, cx + 1), rows], 1),
        ]
    )
    xy, _ = camera.ground_points(uv)
    n = camera.height
    near, side = xy[:n], xy[n:]
    dist = near[:, 0]
    mpp = np.hypot(side[:, 0] - near[:, 0], side[:, 1] - near[:, 1])
    return RowGeometry(distance_m=dist, metres_per_px=mpp, horizon_row=camera.horizon_row())


@dataclass(frozen=True)
class ClassicalExtractor:
    """Classical lane-marking, road and sky extractor (a :class:`SegmentationBackend`).

    Attributes:
        camera: Camera of the images (resized to each image's size); None for a nominal camera.
        params: Extractor parameters.
        name: Backend name.
    """

    camera: CameraModel | None = None
    params: ClassicalParams = field(default_factory=ClassicalParams)
    name: str = "classical"

    def segment(self, image_bgr: ImageBGR) -> LabelImage:
        """Return the ``(H, W)`` uint8 leaf-id image of one BGR image."""
        image = check_image(image_bgr)
        height, width = image.shape[:2]
        geometry = row_geometry(self._camera_for(width, height))
        markings = marking_candidates(image, geometry, self.params)
        road = road_region(image, geometry, markings, self.params)
        margin_px = self.params.road_margin_m / geometry.metres_per_px
        markings &= _within_row_span(road, np.nan_to_num(margin_px, nan=0.0))
        labels = np.zeros((height, width), dtype=np.uint8)
        labels[sky_region(image, geometry, self.params)] = SKY
        labels[road] = ROAD
        classify_markings(image, markings, geometry, self.params, labels)
        return labels

    def segment_batch(self, images_bgr: Sequence[ImageBGR]) -> list[LabelImage]:
        """Return the label images of several BGR images, one by one."""
        return [self.segment(image) for image in images_bgr]

    def _camera_for(self, width: int, height: int) -> CameraModel:
        if self.camera is None:
            return nominal_camera(width, height)
        if (self.camera.width, self.camera.height) != (width, height):
            return self.camera.resized(width, height)
        return self.camera


def expected_marking_px(geometry: RowGeometry, params: ClassicalParams) -> FloatArray:
    """Return the expected painted-line width of each row in pixels (0 where not usable)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        width = params.marking_width_m / geometry.metres_per_px
    usable = np.isfinite(width) & (geometry.distance_m <= params.max_distance_m)
    return np.where(usable, width, 0.0)


def marking_candidates(
    image_bgr: ImageBGR, geometry: RowGeometry, params: ClassicalParams
) -> BoolArray:
    """Return the ``(H, W)`` mask of thin bright ridges of plausible paint width per row."""
    import cv2  # late: heavy import

    height, width = image_bgr.shape[:2]
    raw = (image_bgr[:, :, 1].astype(np.float32) + image_bgr[:, :, 2]) * 0.5
    if params.yellow_gain > 0:
        # Yellow paint on grey asphalt barely out-shines it; its blue deficit does not.
        raw += params.yellow_gain * np.maximum(raw - image_bgr[:, :, 0] - 10.0, 0.0)
    bright = np.asarray(cv2.GaussianBlur(raw, (3, 3), 0), dtype=np.float32)
    w_px = expected_marking_px(geometry, params)
    offsets = np.where(
        w_px > 0,
        np.maximum(params.min_offset_px, np.rint(params.ridge_offset_factor * w_px)),
        0,
    ).astype(np.int64)
    response = np.zeros((height, width), dtype=np.float32)
    # Offsets change monotonically down the image, so rows sharing one form few runs: slices.
    change = np.flatnonzero(np.diff(offsets)) + 1
    for start, stop in zip(
        np.concatenate(([0], change)), np.concatenate((change, [height])), strict=True
    ):
        off = int(offsets[start])
        if off <= 0 or 2 * off >= width:
            continue
        block = bright[start:stop]
        centre = block[:, off:-off]
        response[start:stop, off:-off] = np.minimum(
            centre - block[:, : -2 * off], centre - block[:, 2 * off :]
        )
    mask = response >= params.contrast_min
    mask &= _runs_not_wider_than(mask, params.max_run_factor * np.maximum(w_px, 1.0))
    return _elongated_components(mask, geometry, params)


def _runs_not_wider_than(mask: BoolArray, max_width_px: FloatArray) -> BoolArray:
    """Return the pixels of ``mask`` in horizontal runs no wider than the row's limit."""
    height, width = mask.shape
    padded = np.zeros((height, width + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    diff = np.diff(padded, axis=1)
    r_start, c_start = np.nonzero(diff == 1)
    _, c_stop = np.nonzero(diff == -1)
    run_len = c_stop - c_start
    wide = run_len > max_width_px[r_start]
    kept = mask.copy()
    if wide.any():
        lengths = run_len[wide]
        first = r_start[wide] * width + c_start[wide]
        offsets = np.arange(lengths.sum()) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        kept.ravel()[np.repeat(first, lengths) + offsets] = False
    return kept


def _elongated_components(
    mask: BoolArray, geometry: RowGeometry, params: ClassicalParams
) -> BoolArray:
    """Return ``mask`` without components that are neither line-like nor dot-like.

    Line-like: at least ``min_component_px`` pixels and ``min_elongation``. Dot-like (Botts'
    dots, raised reflectors): the component's width and height fit a dot of ``dot_diameter_m``
    seen at the component's mean row (within a factor ``dot_size_tolerance``).
    """
    import cv2  # late: heavy import

    n, labels = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return mask
    rows, cols = np.nonzero(labels)
    lab = np.asarray(labels[rows, cols], dtype=np.int64)
    x = cols.astype(np.float64)
    y = rows.astype(np.float64)
    count = np.bincount(lab, minlength=n).astype(np.float64)
    safe = np.maximum(count, 1.0)
    mx = np.bincount(lab, x, n) / safe
    my = np.bincount(lab, y, n) / safe
    sxx = np.bincount(lab, x * x, n) / safe - mx * mx
    syy = np.bincount(lab, y * y, n) / safe - my * my
    sxy = np.bincount(lab, x * y, n) / safe - mx * my
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(half_tr**2 - (sxx * syy - sxy**2), 0.0))
    major = half_tr + disc
    minor = np.maximum(half_tr - disc, 1.0 / 12.0)  # a one-pixel-wide line has variance 1/12
    elongation = np.sqrt(major / minor)
    keep = (count >= params.min_component_px) & (elongation >= params.min_elongation)
    if params.dot_diameter_m > 0:
        keep |= _dot_like(lab, rows, cols, count, my, geometry, params)
    keep[0] = False
    kept: BoolArray = keep[labels]
    return kept


def _dot_like(
    lab: IntArray,
    rows: IntArray,
    cols: IntArray,
    count: FloatArray,
    mean_row: FloatArray,
    geometry: RowGeometry,
    params: ClassicalParams,
) -> BoolArray:
    """Return per component whether its bounding box fits a road dot at its mean row."""
    n = count.size
    top = np.full(n, np.iinfo(np.int64).max)
    bottom = np.zeros(n, dtype=np.int64)
    left = np.full(n, np.iinfo(np.int64).max)
    right = np.zeros(n, dtype=np.int64)
    np.minimum.at(top, lab, rows)
    np.maximum.at(bottom, lab, rows)
    np.minimum.at(left, lab, cols)
    np.maximum.at(right, lab, cols)
    row = np.clip(np.rint(mean_row), 0, geometry.distance_m.size - 1).astype(np.int64)
    dist = geometry.distance_m
    # Image rows per forward metre: a dot of diameter d spans d * rows_per_m rows.
    rows_per_m = 1.0 / np.maximum(np.abs(np.gradient(dist)), 1e-6)
    with np.errstate(invalid="ignore", divide="ignore"):
        dot_w = params.dot_diameter_m / geometry.metres_per_px[row]
        dot_h = params.dot_diameter_m * rows_per_m[row]
    tol = params.dot_size_tolerance
    box_w = (right - left + 1).astype(np.float64)
    box_h = (bottom - top + 1).astype(np.float64)
    ok = np.isfinite(dot_w) & np.isfinite(dot_h) & (dist[row] <= params.max_distance_m)
    ok &= (box_w >= dot_w / tol) & (box_w <= dot_w * tol + 1)
    ok &= box_h <= dot_h * tol + 2
    ok &= count >= 2
    out: BoolArray = np.where(ok, True, False)
    return out


def road_region(
    image_bgr: ImageBGR, geometry: RowGeometry, markings: BoolArray, params: ClassicalParams
) -> BoolArray:
    """Return the road mask: pixels like the bottom-centre patch, connected to it."""
    import cv2  # late: heavy import

    height, width = image_bgr.shape[:2]
    small_w = min(params.road_width_px, width)
    small_h = max(8, round(height * small_w / width))
    small = cv2.resize(image_bgr, (small_w, small_h), interpolation=cv2.INTER_AREA)
    lab = cv2.cvtColor(small, cv2.COLOR_BGR2LAB).astype(np.float32)
    seed = np.zeros((small_h, small_w), dtype=bool)
    seed[int(small_h * 0.88) : small_h - 1, int(small_w * 0.4) : int(small_w * 0.6)] = True
    pix = lab[seed]
    med = np.median(pix, axis=0)
    mad = 1.4826 * np.median(np.abs(pix - med), axis=0)
    scale = np.maximum(mad, np.array([12.0, 3.0, 3.0], dtype=np.float32))
    z = np.sqrt((((lab - med) / scale) ** 2).sum(axis=2))
    small_marks = (
        cv2.resize(markings.astype(np.uint8), (small_w, small_h), interpolation=cv2.INTER_AREA) > 0
    )
    below = np.arange(small_h)[:, None] * (height / small_h) > geometry.horizon_row + 2
    cand = ((z <= params.road_max_z) | small_marks | seed) & below
    cand = cv2.morphologyEx(cand.astype(np.uint8), cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
    n, labels = cv2.connectedComponents(cand, connectivity=4)
    if n <= 1:
        return np.zeros((height, width), dtype=bool)
    votes = np.bincount(labels[seed], minlength=n)
    votes[0] = 0
    region = (labels == int(np.argmax(votes))).astype(np.uint8)
    region = cv2.morphologyEx(region, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    full = cv2.resize(region, (width, height), interpolation=cv2.INTER_NEAREST) > 0
    rows_ok = geometry.distance_m <= params.max_distance_m * 2
    out: BoolArray = full & rows_ok[:, None]
    return out


def _within_row_span(region: BoolArray, margin_px: FloatArray) -> BoolArray:
    """Return the mask of pixels within ``margin_px`` of the row's ``region`` span."""
    width = region.shape[1]
    has = region.any(axis=1)
    first = np.where(has, region.argmax(axis=1) - margin_px, width)
    last = np.where(has, width - 1 - region[:, ::-1].argmax(axis=1) + margin_px, -1)
    cols = np.arange(width)[None, :]
    span: BoolArray = (cols >= first[:, None]) & (cols <= last[:, None])
    return span


def sky_region(image_bgr: ImageBGR, geometry: RowGeometry, params: ClassicalParams) -> BoolArray:
    """Return the sky mask: smooth, not green, bright-or-bluish, above the horizon, from the top."""
    import cv2  # late: heavy import

    height, width = image_bgr.shape[:2]
    small_w = min(params.road_width_px, width)
    small_h = max(8, round(height * small_w / width))
    small = cv2.resize(image_bgr, (small_w, small_h), interpolation=cv2.INTER_AREA)
    grey = cv2.cvtColor(small, cv2.COLOR_BGR2GRAY).astype(np.float32)
    sobel = np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1)) / 8.0
    grad = np.asarray(cv2.GaussianBlur(sobel, (3, 3), 0), dtype=np.float32)
    b, g, r = (small[:, :, i].astype(np.int16) for i in range(3))
    not_green = g <= np.maximum(b, r) + 8
    bright_or_blue = (grey >= np.percentile(grey, 60)) | (b > r + 10)
    above = np.arange(small_h)[:, None] * (height / small_h) < geometry.horizon_row - 2
    cand = (grad <= params.sky_max_gradient) & not_green & bright_or_blue & above
    n, labels = cv2.connectedComponents(cand.astype(np.uint8), connectivity=4)
    if n <= 1:
        return np.zeros((height, width), dtype=bool)
    top = np.unique(labels[0][labels[0] > 0])
    small_sky = np.isin(labels, top).astype(np.uint8)
    out: BoolArray = cv2.resize(small_sky, (width, height), interpolation=cv2.INTER_NEAREST) > 0
    return out


def classify_markings(
    image_bgr: ImageBGR,
    markings: BoolArray,
    geometry: RowGeometry,
    params: ClassicalParams,
    labels: LabelImage,
) -> None:
    """Write marking leaf ids into ``labels``: yellow 15, white dashed 14, white solid 13."""
    import cv2  # late: heavy import

    n, comp = cv2.connectedComponents(markings.astype(np.uint8), connectivity=8)
    if n <= 1:
        return
    hsv = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)
    sel = comp > 0
    lab = np.asarray(comp[sel], dtype=np.int64)
    hue, sat = hsv[:, :, 0][sel], hsv[:, :, 1][sel]
    lo, hi = params.yellow_hue
    yellowish = (hue >= lo) & (hue <= hi) & (sat >= params.yellow_min_saturation)
    count = np.maximum(np.bincount(lab, minlength=n), 1)
    yellow = np.bincount(lab, yellowish.astype(np.float64), n) / count > 0.5
    rows = np.nonzero(sel)[0]
    dist = np.nan_to_num(geometry.distance_m[rows], nan=params.max_distance_m)
    near = np.full(n, np.inf)
    far = np.zeros(n)
    np.minimum.at(near, lab, dist)
    np.maximum.at(far, lab, dist)
    dashed = (far - near) < params.dash_max_length_m
    ids = np.where(yellow, YELLOW_SOLID, np.where(dashed, WHITE_DASHED, WHITE_SOLID))
    labels[sel] = ids[lab].astype(np.uint8)
