"""The simulated road: clothoid plan, vertical profile, lane layout, and the road ahead of a pose.

World frame: ENU-like, ``X`` east, ``Y`` north, ``Z`` up, metres, origin at the road's start.
The reference line is the road's **leftmost painted line** (``l = 0``); lines to its right have
negative offsets. Arc length ``s`` is measured along the horizontal projection of the reference
line (metres).

Horizontal plan: curvature ``k(s)`` is piecewise linear through knots (a sequence of clothoid
segments, so curvature is continuous), ``|k| <= 1/150`` 1/m. Heading is its exact integral and
positions are integrated numerically on a 0.1 m grid (error well below a millimetre per km).
Vertical profile: the grade ``dZ/ds`` is piecewise linear through knots, so elevation is a
sequence of straight grades joined by parabolic vertical curves (crests and sags).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.scene import LaneLine, LineColor, LineStyle, RoadProfile

FloatArray = NDArray[np.float64]

MAX_CURVATURE = 1.0 / 150.0
"""Largest curvature of the road plan, 1/m."""
MAX_GRADE = 0.08
"""Largest grade of the vertical profile (8 %)."""
TABLE_STEP_M = 0.1
"""Arc-length step of the dense road tables, metres."""


@dataclass(frozen=True)
class RoadRecipe:
    """How to generate a road (the random parts are drawn from a seeded generator).

    Attributes:
        lane_widths_m: Width of each lane, left to right, metres (2.8-3.9 m each).
        curviness: 0 straight, 1 frequent curves up to the maximum curvature.
        hilliness: 0 flat, 1 grades up to +-8 %.
        dash_m: Dash length of dashed lines, metres.
        gap_m: Gap length of dashed lines, metres.
        left_edge: Style of the leftmost line (``solid`` or ``double``).
        left_color: Colour of the leftmost line.
        oncoming_lanes: Number of lanes (from the left) carrying oncoming traffic; the line after
            them is a double yellow.
        shoulder_m: Paved shoulder outside the outermost lines, metres.
        curb_height_m: Curb height at the paved edges, metres.
        sidewalk_m: Sidewalk width beyond the curbs, metres.
        surface: ``asphalt`` or ``concrete``.
        intersection_spacing_m: Distance between urban intersections (0 for none), metres.
        merge: Add a lane drop (rightmost lane merges) and, later, a lane split.
        wear: Paint wear of every line (0 fresh, 1 invisible).
        line_width_m: Paint width, metres.
    """

    lane_widths_m: tuple[float, ...] = (3.7, 3.7, 3.7)
    curviness: float = 0.0
    hilliness: float = 0.0
    dash_m: float = 3.0
    gap_m: float = 9.0
    left_edge: str = "solid"
    left_color: str = "yellow"
    oncoming_lanes: int = 0
    shoulder_m: float = 2.5
    curb_height_m: float = 0.0
    sidewalk_m: float = 0.0
    surface: str = "asphalt"
    intersection_spacing_m: float = 0.0
    merge: bool = False
    wear: float = 0.0
    line_width_m: float = 0.15

    def validate(self) -> None:
        """Check the recipe describes a possible road.

        Raises:
            ScenarioError: If the lane count or a width is outside the supported range.
        """
        if not 2 <= len(self.lane_widths_m) <= 5:
            raise ScenarioError(f"a road needs 2-5 lanes, got {len(self.lane_widths_m)}")
        bad = [w for w in self.lane_widths_m if not 2.8 <= w <= 3.9]
        if bad:
            raise ScenarioError(f"lane widths must be 2.8-3.9 m, got {bad}")
        if not 0 <= self.oncoming_lanes < len(self.lane_widths_m):
            raise ScenarioError("oncoming_lanes must leave at least one lane for the ego vehicle")


@dataclass(frozen=True)
class LineSlot:
    """Where one longitudinal painted line sits in the lane layout.

    Attributes:
        slot: Index of the line, 0 = leftmost.
        lane_left: Index of the lane on its right (-1 for none) -- the line is that lane's left.
    """

    slot: int
    lane_left: int


@dataclass(frozen=True)
class Road:
    """A generated road: dense tables over arc length plus the painted layout.

    Attributes:
        s_m: Arc-length grid, metres (step ``TABLE_STEP_M``).
        x_m: East position of the reference line, metres.
        y_m: North position of the reference line, metres.
        z_m: Elevation, metres.
        heading_rad: Heading of the reference line, radians from east, counter-clockwise.
        curvature: Curvature of the reference line, 1/m, left positive.
        grade: Grade ``dZ/ds`` (dimensionless).
        lines: Painted line pieces (each a :class:`LaneLine`).
        line_slots: Slot index of each piece (parallel to ``lines``).
        lane_widths_m: Lane widths left to right, metres.
        recipe: The recipe it was built from.
        crosswalks_s_m: Crosswalk arc-length ranges.
        stop_lines_s_m: Stop line arc lengths.
    """

    s_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    z_m: FloatArray
    heading_rad: FloatArray
    curvature: FloatArray
    grade: FloatArray
    lines: tuple[LaneLine, ...]
    line_slots: tuple[int, ...]
    lane_widths_m: tuple[float, ...]
    recipe: RoadRecipe
    crosswalks_s_m: tuple[tuple[float, float], ...] = ()
    stop_lines_s_m: tuple[float, ...] = ()

    @property
    def length_m(self) -> float:
        """Total length of the road, metres."""
        return float(self.s_m[-1])

    def lane_center_m(self, lane: int) -> float:
        """Return the lateral offset of lane ``lane``'s centre (0 = leftmost), metres."""
        widths = self.lane_widths_m
        return -float(sum(widths[:lane]) + widths[lane] / 2.0)

    @property
    def right_edge_m(self) -> float:
        """Offset of the right paved edge, metres (< 0)."""
        return -float(sum(self.lane_widths_m)) - self.recipe.shoulder_m

    @property
    def left_edge_m(self) -> float:
        """Offset of the left paved edge, metres (> 0)."""
        return self.recipe.shoulder_m

    def sample(self, s_m: FloatArray) -> dict[str, FloatArray]:
        """Interpolate the road tables at arc lengths ``s_m``.

        Returns:
            Mapping with ``x``, ``y``, ``z``, ``heading``, ``curvature``, ``grade``.
        """
        s = np.clip(np.asarray(s_m, dtype=np.float64), self.s_m[0], self.s_m[-1])
        return {
            "x": np.interp(s, self.s_m, self.x_m),
            "y": np.interp(s, self.s_m, self.y_m),
            "z": np.interp(s, self.s_m, self.z_m),
            "heading": np.interp(s, self.s_m, self.heading_rad),
            "curvature": np.interp(s, self.s_m, self.curvature),
            "grade": np.interp(s, self.s_m, self.grade),
        }


def _curvature_knots(
    rng: np.random.Generator, length_m: float, curviness: float
) -> tuple[FloatArray, FloatArray]:
    """Draw clothoid knots ``(s, k)``: straights, transitions, arcs, and S-bends."""
    s_knots, k_knots = [0.0], [0.0]
    s = float(rng.uniform(40.0, 90.0)) if curviness > 0 else length_m
    s_knots.append(s)
    k_knots.append(0.0)
    while s < length_m and curviness > 0:
        k_target = float(rng.uniform(0.35, 1.0)) * MAX_CURVATURE * min(1.0, curviness)
        k_target *= 1.0 if rng.random() < 0.5 else -1.0
        if k_knots[-1] != 0.0 and rng.random() < 0.4:
            k_target = -np.sign(k_knots[-1]) * abs(k_target)  # S-bend
        transition = float(rng.uniform(40.0, 90.0))
        arc = float(rng.uniform(40.0, 160.0))
        s += transition
        s_knots.append(s)
        k_knots.append(k_target)
        s += arc
        s_knots.append(s)
        k_knots.append(k_target)
        if rng.random() < 0.6 / max(curviness, 0.1):
            s += float(rng.uniform(40.0, 90.0))
            s_knots.append(s)
            k_knots.append(0.0)
            s += float(rng.uniform(20.0, 200.0) / max(curviness, 0.2))
            s_knots.append(s)
            k_knots.append(0.0)
    s_knots.append(max(s, length_m) + 1.0)
    k_knots.append(k_knots[-1])
    return np.asarray(s_knots), np.asarray(k_knots)


def _grade_knots(
    rng: np.random.Generator, length_m: float, hilliness: float
) -> tuple[FloatArray, FloatArray]:
    """Draw grade knots ``(s, g)``: constant grades joined by vertical curves of 60-200 m."""
    s_knots, g_knots = [0.0], [0.0]
    s = 0.0
    grade = 0.0
    while s < length_m:
        hold = float(rng.uniform(30.0, 120.0))
        s += hold
        s_knots.append(s)
        g_knots.append(grade)
        if hilliness <= 0:
            continue
        target = float(rng.uniform(-1.0, 1.0)) * MAX_GRADE * min(1.0, hilliness)
        if abs(target - grade) < 0.02 * hilliness:
            target = -grade if grade else MAX_GRADE * hilliness * 0.6
        length = float(rng.uniform(60.0, 200.0))
        s += length
        grade = target
        s_knots.append(s)
        g_knots.append(grade)
    s_knots.append(s + 1.0)
    g_knots.append(grade)
    return np.asarray(s_knots), np.asarray(g_knots)


def _integrate_plan(
    s: FloatArray, k: FloatArray, heading0_rad: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Integrate curvature to heading and position (trapezoid on the fine grid)."""
    ds = np.diff(s)
    heading = heading0_rad + np.concatenate([[0.0], np.cumsum(0.5 * (k[1:] + k[:-1]) * ds)])
    mid = heading[:-1] + 0.5 * k[:-1] * ds + (k[1:] - k[:-1]) * ds / 8.0  # exact mid-step heading
    x = np.concatenate([[0.0], np.cumsum(np.cos(mid) * ds)])
    y = np.concatenate([[0.0], np.cumsum(np.sin(mid) * ds)])
    return heading, x, y


def _line_layout(recipe: RoadRecipe) -> list[tuple[float, LineStyle, LineColor, int]]:
    """Return the painted slots as ``(offset, style, colour, lane_on_right)`` left to right."""
    widths = recipe.lane_widths_m
    slots: list[tuple[float, LineStyle, LineColor, int]] = []
    offset = 0.0
    left_style = LineStyle(recipe.left_edge)
    slots.append((0.0, left_style, LineColor(recipe.left_color), 0))
    for lane, width in enumerate(widths):
        offset -= width
        if lane == len(widths) - 1:
            slots.append((offset, LineStyle.SOLID, LineColor.WHITE, -1))
        elif recipe.oncoming_lanes and lane == recipe.oncoming_lanes - 1:
            slots.append((offset, LineStyle.DOUBLE, LineColor.YELLOW, lane + 1))
        else:
            slots.append((offset, LineStyle.DASHED, LineColor.WHITE, lane + 1))
    return slots


def _pieces(start: float, end: float, gaps: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Split ``[start, end)`` by removing the ``gaps`` ranges."""
    out: list[tuple[float, float]] = []
    cur = start
    for g0, g1 in sorted(gaps):
        if g0 > cur:
            out.append((cur, min(g0, end)))
        cur = max(cur, g1)
    if cur < end:
        out.append((cur, end))
    return out


def build_road(recipe: RoadRecipe, length_m: float, rng: np.random.Generator) -> Road:
    """Generate a road of ``length_m`` metres from ``recipe`` with random draws from ``rng``.

    Raises:
        ScenarioError: If the recipe is impossible or the length is not positive.
    """
    recipe.validate()
    if not length_m > 0:
        raise ScenarioError(f"road length must be positive, got {length_m} m")
    n = int(np.ceil(length_m / TABLE_STEP_M)) + 1
    s = np.arange(n, dtype=np.float64) * TABLE_STEP_M
    sk, kk = _curvature_knots(rng, length_m, recipe.curviness)
    k = np.interp(s, sk, kk)
    heading0 = float(rng.uniform(-np.pi, np.pi))
    heading, x, y = _integrate_plan(s, k, heading0)
    sg, gg = _grade_knots(rng, length_m, recipe.hilliness)
    grade = np.interp(s, sg, gg)
    z = np.concatenate([[0.0], np.cumsum(0.5 * (grade[1:] + grade[:-1]) * np.diff(s))])

    crosswalks, stop_lines, gaps = _intersections(rng, length_m, recipe.intersection_spacing_m)
    lines, slots_out = _painted_lines(recipe, length_m, gaps, rng)
    return Road(
        s_m=s,
        x_m=x,
        y_m=y,
        z_m=z,
        heading_rad=heading,
        curvature=k,
        grade=grade,
        lines=tuple(lines),
        line_slots=tuple(slots_out),
        lane_widths_m=recipe.lane_widths_m,
        recipe=recipe,
        crosswalks_s_m=tuple(crosswalks),
        stop_lines_s_m=tuple(stop_lines),
    )


def _intersections(
    rng: np.random.Generator, length_m: float, spacing_m: float
) -> tuple[list[tuple[float, float]], list[float], list[tuple[float, float]]]:
    """Draw urban intersections every ``spacing_m`` (+-25 %) metres (none for 0).

    Returns:
        ``(crosswalks, stop_lines, gaps)``: the crosswalk ``[start, end)`` ranges and stop-line
        arc lengths, and the ranges where the longitudinal lines stop, metres.
    """
    crosswalks: list[tuple[float, float]] = []
    stop_lines: list[float] = []
    gaps: list[tuple[float, float]] = []
    if spacing_m > 0:
        s_int = float(rng.uniform(60.0, 120.0))
        while s_int < length_m - 30.0:
            stop_lines.append(s_int)
            crosswalks.append((s_int + 1.5, s_int + 5.5))
            crosswalks.append((s_int + 21.5, s_int + 25.5))
            gaps.append((s_int, s_int + 27.0))
            s_int += spacing_m * float(rng.uniform(0.8, 1.25))
    return crosswalks, stop_lines, gaps


def _painted_lines(
    recipe: RoadRecipe,
    length_m: float,
    gaps: list[tuple[float, float]],
    rng: np.random.Generator,
) -> tuple[list[LaneLine], list[int]]:
    """Return the painted line pieces and the slot of each, interrupted at the ``gaps``.

    With ``recipe.merge`` the right edge tapers in over a lane drop and out again over a lane
    split, and the line left of the rightmost lane stops between the two.
    """
    widths = recipe.lane_widths_m
    lines: list[LaneLine] = []
    slots_out: list[int] = []
    layout = _line_layout(recipe)
    merge_s = float(rng.uniform(0.25, 0.35)) * length_m if recipe.merge else np.nan
    split_s = float(rng.uniform(0.6, 0.7)) * length_m if recipe.merge else np.nan
    taper = 90.0
    for slot, (offset, style, color, _) in enumerate(layout):
        dashed = style == LineStyle.DASHED
        base = LaneLine(
            offset_m=offset,
            style=style,
            color=color,
            width_m=recipe.line_width_m,
            dash_m=recipe.dash_m if dashed else 0.0,
            gap_m=recipe.gap_m if dashed else 0.0,
            phase_m=float(rng.uniform(0.0, recipe.dash_m + recipe.gap_m)) if dashed else 0.0,
            wear=recipe.wear,
        )
        last = slot == len(layout) - 1
        second_last = slot == len(layout) - 2
        spans = _pieces(-50.0, length_m + 50.0, gaps)
        for a, b in spans:
            piece = _replace_span(base, a, b)
            if recipe.merge and last:
                # right edge: taper inwards over the merge, back out over the split
                for (a2, b2), (t0, delta) in (
                    ((a, split_s), (merge_s, widths[-1])),
                    ((split_s, b), (split_s, -widths[-1])),
                ):
                    start_off = offset if t0 == merge_s else offset + widths[-1]
                    lines.append(
                        _replace_taper(_replace_span(base, a2, b2), start_off, t0, taper, delta)
                    )
                    slots_out.append(slot)
                continue
            if recipe.merge and second_last:
                for a2, b2 in ((a, merge_s + taper), (split_s + taper, b)):
                    lines.append(_replace_span(base, a2, b2))
                    slots_out.append(slot)
                continue
            lines.append(piece)
            slots_out.append(slot)
    return lines, slots_out


def _replace_span(line: LaneLine, start: float, end: float) -> LaneLine:
    return replace(line, start_s_m=start, end_s_m=end)


def _replace_taper(
    line: LaneLine, offset: float, start: float, length: float, delta: float
) -> LaneLine:
    return replace(
        line, offset_m=offset, taper_start_s_m=start, taper_length_m=length, taper_delta_m=delta
    )


@dataclass(frozen=True)
class EgoPose:
    """The ego vehicle's pose in the world.

    Attributes:
        s_m: Arc length of the closest reference-line point, metres.
        x_m: East position of the vehicle origin, metres.
        y_m: North position, metres.
        z_m: Elevation of the road under the vehicle, metres.
        heading_rad: Heading of the vehicle, radians from east, counter-clockwise.
        pitch_rad: Nose-up pitch of the vehicle (the road grade angle), radians.
    """

    s_m: float
    x_m: float
    y_m: float
    z_m: float
    heading_rad: float
    pitch_rad: float


def world_to_vehicle(
    pose: EgoPose, x_m: FloatArray, y_m: FloatArray, z_m: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Express world points in the vehicle frame of ``pose`` (x forward, y left, z up)."""
    dx = np.asarray(x_m) - pose.x_m
    dy = np.asarray(y_m) - pose.y_m
    dz = np.asarray(z_m) - pose.z_m
    ch, sh = np.cos(pose.heading_rad), np.sin(pose.heading_rad)
    xh = ch * dx + sh * dy
    yv = -sh * dx + ch * dy
    cp, sp = np.cos(pose.pitch_rad), np.sin(pose.pitch_rad)
    return cp * xh + sp * dz, yv, -sp * xh + cp * dz


def road_ahead(
    road: Road,
    pose: EgoPose,
    ahead_m: float = 200.0,
    behind_m: float = 10.0,
    step_m: float = 0.5,
) -> RoadProfile:
    """Return the road from ``behind_m`` behind to ``ahead_m`` ahead of ``pose``, vehicle frame.

    Samples every ``step_m`` metres of arc length; the profile stops early where the road would
    turn through more than 80 degrees relative to the vehicle (keeps ``x`` increasing).
    """
    s = np.arange(pose.s_m - behind_m, pose.s_m + ahead_m + 1e-9, step_m)
    s = s[(s >= road.s_m[0]) & (s <= road.s_m[-1])]
    smp = road.sample(s)
    xv, yv, zv = world_to_vehicle(pose, smp["x"], smp["y"], smp["z"])
    rel_heading = (smp["heading"] - pose.heading_rad + np.pi) % (2 * np.pi) - np.pi
    keep = np.abs(rel_heading) < np.deg2rad(80.0)
    if not keep.all():
        stop = int(np.argmin(keep))
        s, xv, yv, zv = s[:stop], xv[:stop], yv[:stop], zv[:stop]
    heading = np.arctan2(np.gradient(yv), np.gradient(xv)) if len(s) > 1 else rel_heading[:1]
    lo, hi = float(s[0]), float(s[-1])
    visible = tuple(ln for ln in road.lines if ln.end_s_m > lo and ln.start_s_m < hi)
    return RoadProfile(
        s_m=s,
        x_m=xv,
        y_m=yv,
        z_m=zv,
        heading_rad=heading,
        lines=visible,
        left_edge_m=road.left_edge_m,
        right_edge_m=road.right_edge_m,
        shoulder_m=road.recipe.shoulder_m,
        curb_height_m=road.recipe.curb_height_m,
        sidewalk_m=road.recipe.sidewalk_m,
        surface=road.recipe.surface,
        crosswalks_s_m=tuple(c for c in road.crosswalks_s_m if c[1] > lo and c[0] < hi),
        stop_lines_s_m=tuple(v for v in road.stop_lines_s_m if lo < v < hi),
    )


def line_points(
    profile: RoadProfile, line: LaneLine, s_m: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Return ``(s, xyz)`` of a line's centre in the vehicle frame (``(N, 3)``, metres).

    Points are offset from the reference line along its normal in the road plane, exactly as
    the renderer paints them; only arc lengths inside the line's ``[start, end)`` are returned.
    """
    s = profile.s_m if s_m is None else np.asarray(s_m, dtype=np.float64)
    s = s[(s >= line.start_s_m) & (s < line.end_s_m) & (s >= profile.s_m[0])]
    s = s[s <= profile.s_m[-1]]
    x = np.interp(s, profile.s_m, profile.x_m)
    y = np.interp(s, profile.s_m, profile.y_m)
    z = np.interp(s, profile.s_m, profile.z_m)
    h = np.interp(s, profile.s_m, profile.heading_rad)
    off = line.offset_at(s)
    return s, np.stack([x - off * np.sin(h), y + off * np.cos(h), z], axis=1)
