"""Per-lane marking attributes: from level-4 classes, else from the image and pixel support."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

IntArray = NDArray[np.intp]


class Marking(NamedTuple):
    """Colour and style of a lane-marking class."""

    colour: str
    style: str


UNKNOWN = Marking("unknown", "unknown")

MARKING_CODES: tuple[tuple[str, Marking], ...] = (
    ("lane_marking", UNKNOWN),
    ("dividing_white_solid", Marking("white", "solid")),
    ("dividing_white_dashed", Marking("white", "dashed")),
    ("dividing_yellow_solid", Marking("yellow", "solid")),
    ("dividing_yellow_dashed", Marking("yellow", "dashed")),
    ("double_yellow", Marking("yellow", "double")),
    ("double_white", Marking("white", "double")),
    ("white_marking", Marking("white", "unknown")),
    ("yellow_marking", Marking("yellow", "unknown")),
)
"""Level-4 marking classes in code order: a point's attribute code indexes this table."""

CODE_OF = {name: code for code, (name, _) in enumerate(MARKING_CODES)}
"""Class name -> attribute code (0 means an unspecific lane-marking pixel)."""

DASH_COVERAGE = 0.8
"""Below this fraction of covered image rows between a line's ends, the line is dashed."""

MIN_ROWS_FOR_STYLE = 12
"""Lines spanning fewer image rows have an unknown style (too short to see a gap)."""


def marking_from_codes(codes: IntArray) -> Marking:
    """Return the majority colour and style of a line's points from their class codes.

    Args:
        codes: Attribute codes (see :data:`MARKING_CODES`) of the line's points; code 0 and
            unknown codes carry no information.
    """
    c = np.asarray(codes, dtype=np.intp)
    c = c[(c > 0) & (c < len(MARKING_CODES))]
    if c.size == 0:
        return UNKNOWN
    votes = np.bincount(c, minlength=len(MARKING_CODES))
    colours: dict[str, int] = {}
    styles: dict[str, int] = {}
    for code, count in enumerate(votes):
        if count:
            mark = MARKING_CODES[code][1]
            colours[mark.colour] = colours.get(mark.colour, 0) + int(count)
            if mark.style != "unknown":  # colour-only codes (from the image) do not vote on style
                styles[mark.style] = styles.get(mark.style, 0) + int(count)
    style = max(styles, key=lambda k: styles[k]) if styles else "unknown"
    return Marking(max(colours, key=lambda k: colours[k]), style)


YELLOW_MIN_CHROMA = 0.22
"""``(min(R, G) - B) / max(R, G, B)`` above this is yellow paint; below, white (grey) paint."""


def colour_codes_from_image(image_bgr: NDArray[np.uint8], lane_uv: NDArray[np.float64]) -> IntArray:
    """Return colour-only marking codes of lane pixels from the camera image's colour there.

    Used when the segmentation gives no level-4 classes: each lane pixel is looked up in the
    image (nearest pixel, same size as the mask) and classified as yellow paint when its blue
    channel falls well below red and green (:data:`YELLOW_MIN_CHROMA`), else white.

    Args:
        image_bgr: ``(H, W, 3)`` camera image, BGR.
        lane_uv: ``(N, 2)`` lane pixel coordinates ``(u, v)`` in that image, pixels.
    """
    img = np.asarray(image_bgr)
    uv = np.asarray(lane_uv, dtype=np.float64).reshape(-1, 2)
    cols = np.clip(np.round(uv[:, 0]).astype(np.intp), 0, img.shape[1] - 1)
    rows = np.clip(np.round(uv[:, 1]).astype(np.intp), 0, img.shape[0] - 1)
    bgr = img[rows, cols].astype(np.float64)
    b, g, r = bgr[:, 0], bgr[:, 1], bgr[:, 2]
    chroma = (np.minimum(r, g) - b) / np.maximum(np.maximum(r, g), 1.0)
    yellow = chroma > YELLOW_MIN_CHROMA
    return np.where(yellow, CODE_OF["yellow_marking"], CODE_OF["white_marking"]).astype(np.intp)


def style_from_support(rows_px: NDArray[np.float64]) -> str:
    """Return ``solid``/``dashed``/``unknown`` from the image rows of a line's pixels.

    A solid marking covers nearly every image row between its ends; a dashed one leaves gaps.

    Args:
        rows_px: Image rows (pixels) of the line's supporting points.
    """
    rows = np.unique(np.round(np.asarray(rows_px, dtype=np.float64)).astype(np.intp))
    if rows.size == 0:
        return "unknown"
    return style_from_coverage(rows.size, int(rows[-1] - rows[0]) + 1)


def style_from_coverage(n_rows: int, span_rows: int) -> str:
    """Return ``solid``/``dashed``/``unknown`` from a line's covered rows and its row span.

    Args:
        n_rows: Distinct image rows holding the line's pixels.
        span_rows: Rows from the line's first to its last row, inclusive.
    """
    if n_rows == 0 or span_rows < MIN_ROWS_FOR_STYLE:
        return "unknown"
    return "solid" if n_rows / span_rows >= DASH_COVERAGE else "dashed"


def lane_attributes(
    labels: IntArray,
    n_lanes: int,
    rows_px: NDArray[np.float64],
    codes: IntArray | None,
) -> list[Marking]:
    """Return colour and style of each line.

    Args:
        labels: Line index of each lane point (-1: on no line).
        n_lanes: Number of lines.
        rows_px: Image row (pixels) of each lane point.
        codes: Attribute code of each lane point, or None when no level-4 classes are known.
    """
    out = []
    for lane in range(n_lanes):
        mask = labels == lane
        mark = marking_from_codes(codes[mask]) if codes is not None else UNKNOWN
        if mark.style == "unknown":
            mark = Marking(mark.colour, style_from_support(rows_px[mask]))
        out.append(mark)
    return out
