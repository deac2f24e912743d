"""Objects above the road (vehicles, trees, rails, poles, signs, buildings, people) as polygons.

Each :class:`~superlane_tools.simulation.scene.SceneObject` becomes a few boxes whose visible
faces are projected and filled far to near (painter's order) with OpenCV, into a colour layer,
a label layer and a depth layer at the same time, so image and labels always agree. The depth
layer (range from the camera, metres, one value per object part) lets the road occlude objects
behind a crest.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render.foliage import SPRITE_SPAN, crown_sprites, draw_sprite
from superlane_tools.simulation.scene import SceneObject

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]
F64 = NDArray[np.float64]

_SHIFT = 4  # sub-pixel bits for cv2 polygon filling
_NEAR_M = 0.3
_MAX_PIECE_M = 6.0

# Box corners in unit coordinates (along, across, up) and faces with outward normals.
_CORNERS = np.array(
    [[a, b, c] for c in (0.0, 1.0) for b in (-0.5, 0.5) for a in (-0.5, 0.5)], dtype=np.float64
)
_FACES = (
    ((1, 3, 7, 5), (1.0, 0.0, 0.0)),  # front
    ((0, 4, 6, 2), (-1.0, 0.0, 0.0)),  # rear
    ((2, 6, 7, 3), (0.0, 1.0, 0.0)),  # left
    ((0, 1, 5, 4), (0.0, -1.0, 0.0)),  # right
    ((4, 5, 7, 6), (0.0, 0.0, 1.0)),  # top
)


Detail = tuple[float, float, float, float, tuple[float, ...]]


class Light(NamedTuple):
    """A small light source seen in the image (for bloom and night glow)."""

    u: float
    v: float
    radius_px: float
    color_bgr: tuple[float, float, float]
    intensity: float


class Layers(NamedTuple):
    """Full-frame object layers (``labels`` is 0 and ``depth`` meaningless where no object is).

    ``shadow`` (contact shadow darkness 0..1 on the ground) has half the resolution.
    """

    color: U8
    labels: U8
    depth: F32
    shadow: F32
    lights: list[Light]


class _Box(NamedTuple):
    centre: F64  # bottom centre, vehicle frame
    size: F64  # length, width, height
    yaw: float
    taper: tuple[float, float] = (0.0, 0.0)  # top face shrunk by these fractions (along, across)


def _seed(obj: SceneObject) -> int:
    key = (
        f"{obj.kind}{obj.style}{obj.length_m:.3f}{obj.width_m:.3f}{obj.height_m:.3f}{obj.color_bgr}"
    )
    return zlib.crc32(key.encode())


def _box_points(box: _Box, unit: F64) -> F64:
    c, sz = np.cos(box.yaw), np.sin(box.yaw)
    p = unit * box.size
    x = box.centre[0] + c * p[:, 0] - sz * p[:, 1]
    y = box.centre[1] + sz * p[:, 0] + c * p[:, 1]
    z = box.centre[2] + p[:, 2]
    return np.stack([x, y, z], axis=1)


_Queued = tuple[_Box, tuple[float, ...], int, dict[int, list[Detail]] | None] | Callable[[], None]


class _Painter:
    """Fills projected polygons into the layers."""

    def __init__(
        self,
        camera: CameraModel,
        layers: Layers,
        daylight: float,
        haze_bgr: tuple[float, float, float],
        vis_m: float,
    ) -> None:
        self.camera = camera
        self.layers = layers
        self.cam_pos = camera.extrinsics.position
        self.rot = camera.extrinsics.rotation
        k = camera.intrinsics
        self.fxy = np.array([k.fx, k.fy])
        self.cxy = np.array([k.cx, k.cy])
        self.distorted = k.has_distortion
        self.size = (k.width, k.height)
        self.daylight = daylight
        self.sun = np.array([0.3, 0.5, 0.8])
        self.queue: list[_Queued] = []
        self.haze_bgr = haze_bgr
        self.vis_m = vis_m

    def hazed(self, color: tuple[float, ...], depth: float) -> tuple[float, float, float]:
        """Return ``color`` seen through the haze at ``depth`` metres (Koschmieder's law)."""
        k = float(np.exp(-3.0 * min(depth, 1e5) / self.vis_m))
        hz = self.haze_bgr
        return (
            color[0] * k + hz[0] * (1.0 - k),
            color[1] * k + hz[1] * (1.0 - k),
            color[2] * k + hz[2] * (1.0 - k),
        )

    def project(self, pts: F64) -> F64 | None:
        """Return ``(N, 2)`` pixel positions of vehicle-frame points, None if any is too near."""
        pc = (pts - self.cam_pos) @ self.rot
        if float(pc[:, 2].min()) < _NEAR_M:
            return None
        if self.distorted:
            uv, _ = self.camera.project(pts)
            return uv
        out: F64 = pc[:, :2] / pc[:, 2:3] * self.fxy + self.cxy
        return out

    def fill(self, uv: F64, color: tuple[float, ...], label: int, depth: float) -> None:
        """Fill one projected convex polygon into the colour, label and depth layers."""
        self.fill_fixed(np.round(uv * (1 << _SHIFT)).astype(np.int32), color, label, depth)

    def fill_fixed(
        self, ip: NDArray[np.int32], color: tuple[float, ...], label: int, depth: float
    ) -> None:
        """Fill a polygon given in fixed-point pixels (``_SHIFT`` fractional bits)."""
        import cv2

        lay = self.layers
        hz = self.hazed(color, depth)
        col = (min(255.0, hz[0]), min(255.0, hz[1]), min(255.0, hz[2]))
        cv2.fillConvexPoly(lay.color, ip, col, cv2.LINE_AA, _SHIFT)
        cv2.fillConvexPoly(lay.labels, ip, label, cv2.LINE_8, _SHIFT)
        cv2.fillConvexPoly(lay.depth, ip, depth, cv2.LINE_8, _SHIFT)

    def visible(self, uv: F64) -> bool:
        """Return True if the projected points' bounding box overlaps the image."""
        w, h = self.size
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        return bool(hi[0] >= -1 and lo[0] <= w and hi[1] >= -1 and lo[1] <= h)

    def box(
        self,
        box: _Box,
        color: tuple[float, ...],
        label: int,
        details: dict[int, list[Detail]] | None = None,
    ) -> None:
        """Queue a box (visible faces, with detail rectangles on some faces) for :meth:`flush`."""
        self.queue.append((box, color, label, details))

    def later(self, draw: Callable[[], None]) -> None:
        """Queue another drawing step (a sprite) in painter's order."""
        self.queue.append(draw)

    def flush(self) -> None:
        """Draw the queued boxes and steps in order, projecting all boxes at once."""
        boxes = [q for q in self.queue if not callable(q)]
        if boxes:
            centre = np.array([b[0].centre for b in boxes])
            size = np.array([b[0].size for b in boxes])
            yaw = np.array([b[0].yaw for b in boxes])
            c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            # Unit corners, the top ones pulled in by each box's taper (car cabins).
            taper = np.array([b[0].taper for b in boxes])  # (N, 2)
            top = _CORNERS[None, :, 2:3]  # 1 for the top corners
            unit = np.broadcast_to(_CORNERS[None], (len(boxes), 8, 3)).copy()
            unit[..., 0:1] *= 1.0 - top * taper[:, None, 0:1]
            unit[..., 1:2] *= 1.0 - top * taper[:, None, 1:2]
            p = unit * size[:, None, :]
            pts = np.stack(
                [
                    centre[:, 0:1] + c * p[..., 0] - s * p[..., 1],
                    centre[:, 1:2] + s * p[..., 0] + c * p[..., 1],
                    centre[:, 2:3] + p[..., 2],
                ],
                axis=2,
            )
            pc = (pts - self.cam_pos) @ self.rot
            near = pc[..., 2].min(axis=1) < _NEAR_M
            if self.distorted:
                uv = self.camera.project(pts.reshape(-1, 3))[0].reshape(-1, 8, 2)
            else:
                with np.errstate(divide="ignore", invalid="ignore"):
                    uv = pc[..., :2] / pc[..., 2:3] * self.fxy + self.cxy
            w, h = self.size
            lo, hi = uv.min(axis=1), uv.max(axis=1)
            show = ~near & (hi[:, 0] >= -1) & (lo[:, 0] <= w) & (hi[:, 1] >= -1) & (lo[:, 1] <= h)
            mid = centre + np.stack([0 * size[:, 2], 0 * size[:, 2], size[:, 2] / 2], axis=1)
            depth = np.linalg.norm(mid - self.cam_pos, axis=1)
            # Outward face normals and back-face culling, all boxes at once.
            nrm = np.array([n for _, n in _FACES])  # (5, 3)
            nx = c * nrm[None, :, 0] - s * nrm[None, :, 1]
            ny = s * nrm[None, :, 0] + c * nrm[None, :, 1]
            nz = np.broadcast_to(nrm[None, :, 2], nx.shape)
            first = pts[:, [q[0] for q, _ in _FACES], :] - self.cam_pos  # (N, 5, 3)
            front = nx * first[..., 0] + ny * first[..., 1] + nz * first[..., 2] < 0
            lit = 0.62 + 0.38 * np.maximum(0.0, nx * 0.3 + ny * 0.5 + nz * 0.8)
            lit *= 0.35 + 0.65 * self.daylight
            quads = uv[:, [list(q) for q, _ in _FACES], :]  # (N, 5, 4, 2)
            fixed = np.round(np.where(show[:, None, None, None], quads, 0.0) * (1 << _SHIFT))
            fixed_q = np.ascontiguousarray(fixed, dtype=np.int32)
            small = (quads.max(axis=2) - quads.min(axis=2)).min(axis=2) < 3.0  # (N, 5)
            faces = (front & show[:, None]).tolist()
            lit_l, depth_l = lit.tolist(), depth.tolist()
        k = 0
        for item in self.queue:
            if callable(item):
                item()
                continue
            i = k
            k += 1
            if not show[i]:
                continue
            _, color, label, details = item
            for idx, visible in enumerate(faces[i]):
                if not visible:
                    continue
                f = lit_l[i][idx]
                col = (color[0] * f, color[1] * f, color[2] * f)
                self.fill_fixed(fixed_q[i, idx], col, label, depth_l[i])
                if not details or idx not in details or small[i, idx]:
                    continue  # no details, or they would be sub-pixel
                q = quads[i, idx]
                for a0, a1, b0, b1, dcol in details[idx]:
                    self.fill(
                        _subquad(q, a0, a1, b0, b1),
                        (dcol[0] * f, dcol[1] * f, dcol[2] * f),
                        label,
                        depth_l[i],
                    )
        self.queue.clear()

    def shadow(self, box: _Box, grow: float, strength: float) -> None:
        """Draw the soft contact shadow of a box on the ground."""
        ground = _Box(box.centre, box.size * [1.0 + grow, 1.0 + grow, 0.0], box.yaw)
        pts = _box_points(ground, _CORNERS[:4])[[0, 1, 3, 2]]
        uv = self.project(pts)
        if uv is not None and self.visible(uv):
            import cv2

            # The shadow layer has half the resolution (it is blurred anyway).
            ip = np.round((uv + 0.5) * (1 << (_SHIFT - 1)) - 0.5 * (1 << _SHIFT)).astype(np.int32)
            cv2.fillConvexPoly(self.layers.shadow, ip, strength, cv2.LINE_AA, _SHIFT)


def _subquad(q: F64, a0: float, a1: float, b0: float, b1: float) -> F64:
    """Return the sub-rectangle ``[a0, a1] x [b0, b1]`` of a quad (a along edge 0-1, b up).

    Works on projected quads (pixels): bilinear in the image, close enough for small faces.
    Also works on 3D quads (rows of any length).
    """
    p0, p1, p2, p3 = q.tolist()

    def at(a: float, b: float) -> list[float]:
        return [
            (x0 + (x1 - x0) * a) + ((x3 + (x2 - x3) * a) - (x0 + (x1 - x0) * a)) * b
            for x0, x1, x2, x3 in zip(p0, p1, p2, p3, strict=True)
        ]

    return np.array([at(a0, b0), at(a1, b0), at(a1, b1), at(a0, b1)])


def _pieces(obj: SceneObject) -> list[_Box]:
    """Split long objects (rails, walls) into pieces so near-plane clipping stays local."""
    n = max(1, int(np.ceil(obj.length_m / _MAX_PIECE_M)))
    c, s = np.cos(obj.yaw_rad), np.sin(obj.yaw_rad)
    out = []
    for i in range(n):
        a = (i + 0.5) / n - 0.5
        centre = np.array([obj.x_m + c * a * obj.length_m, obj.y_m + s * a * obj.length_m, obj.z_m])
        out.append(
            _Box(centre, np.array([obj.length_m / n, obj.width_m, obj.height_m]), obj.yaw_rad)
        )
    return out


def _scaled(box: _Box, a0: float, a1: float, w: float, z0: float, z1: float) -> _Box:
    """Return a sub-box of ``box``: along fraction [a0, a1], width fraction, height fraction."""
    c, s = np.cos(box.yaw), np.sin(box.yaw)
    mid = (a0 + a1) / 2 - 0.5
    centre = box.centre + np.array([c * mid * box.size[0], s * mid * box.size[0], z0 * box.size[2]])
    size = np.array([(a1 - a0) * box.size[0], w * box.size[1], (z1 - z0) * box.size[2]])
    return _Box(centre, size, box.yaw)


def _vehicle(p: _Painter, obj: SceneObject, label: int) -> None:
    box = _Box(
        np.array([obj.x_m, obj.y_m, obj.z_m]),
        np.array([obj.length_m, obj.width_m, obj.height_m]),
        obj.yaw_rad,
    )
    col = tuple(float(c) for c in obj.color_bgr)
    dark = (22.0, 22.0, 24.0)
    glass = (58.0, 52.0, 50.0)
    tail = (30.0, 30.0, 190.0) if p.daylight > 0.4 else (80.0, 80.0, 255.0)
    p.shadow(box, 0.12, 0.55)
    truck = obj.style in {"truck", "bus", "van"}
    for a0, a1 in ((0.06, 0.24), (0.76, 0.94)):  # wheels
        for w0 in (-1, 1):
            wheel = _scaled(box, a0, a1, 0.22, 0.0, 0.26)
            c, s = np.cos(box.yaw), np.sin(box.yaw)
            off = w0 * 0.39 * obj.width_m
            wheel = _Box(wheel.centre + np.array([-s * off, c * off, 0.0]), wheel.size, box.yaw)
            p.box(wheel, dark, label)
    lamp_rows = (0.55, 0.8) if not truck else (0.1, 0.25)
    rear_details: list[Detail] = [
        (0.0, 1.0, 0.0, 0.22, tuple(0.45 * c for c in col)),
        (0.03, 0.2, *lamp_rows, tail),
        (0.8, 0.97, *lamp_rows, tail),
        (0.4, 0.6, 0.25, 0.45, (200.0, 205.0, 210.0)),
    ]
    front_details: list[Detail] = [
        (0.0, 1.0, 0.0, 0.2, tuple(0.5 * c for c in col)),
        (0.05, 0.22, 0.55, 0.75, (210.0, 220.0, 225.0)),
        (0.78, 0.95, 0.55, 0.75, (210.0, 220.0, 225.0)),
    ]
    if truck:
        cargo = _scaled(box, 0.0, 0.78, 1.0, 0.12, 1.0)
        p.box(cargo, col, label, {1: rear_details})
        cab = _scaled(box, 0.8, 1.0, 0.95, 0.12, 0.8)
        p.box(cab, col, label, {0: [*front_details, (0.1, 0.9, 0.55, 0.95, glass)]})
        return
    body = _scaled(box, 0.0, 1.0, 1.0, 0.12, 0.58)
    p.box(body, col, label, {1: rear_details, 0: front_details})
    cabin = _scaled(box, 0.14, 0.82, 0.9, 0.58, 1.0)._replace(taper=(0.3, 0.14))
    win: list[Detail] = [(0.08, 0.92, 0.1, 0.9, glass)]
    p.box(cabin, col, label, {0: win, 1: win, 2: win, 3: win})
    if p.daylight < 0.6:
        for a in (0.12, 0.88):
            pt = _subquad(_box_points(body, _CORNERS)[[0, 4, 6, 2]], a, a, 0.68, 0.68)[0]
            luv = p.project(pt[None])
            dist = float(np.linalg.norm(pt - p.cam_pos))
            if luv is not None and dist > 1:
                r = max(1.5, 0.25 * p.camera.intrinsics.fx / dist)
                p.layers.lights.append(Light(luv[0, 0], luv[0, 1], r, (60.0, 60.0, 255.0), 1.0))


def _tree(p: _Painter, obj: SceneObject, label: int, rng: np.random.Generator, seed: int) -> None:
    box = _Box(
        np.array([obj.x_m, obj.y_m, obj.z_m]),
        np.array([obj.length_m, obj.width_m, obj.height_m]),
        obj.yaw_rad,
    )
    bush = obj.style == "bush"
    if not bush:
        trunk = _scaled(box, 0.45, 0.55, 0.1, 0.0, 0.45)
        p.box(trunk, (40.0, 55.0, 70.0), label)
    centre = box.centre + np.array([0.0, 0.0, obj.height_m * (0.45 if bush else 0.65)])
    r_m = 0.5 * max(obj.width_m, obj.length_m)
    h_m = obj.height_m * (0.5 if bush else 0.4)
    depth = float(np.linalg.norm(centre - p.cam_pos))
    uv = p.project(centre[None])
    if uv is None or depth < 1.0:
        return
    f = p.camera.intrinsics.fx
    half_u = SPRITE_SPAN * r_m * f / depth
    half_v = SPRITE_SPAN * h_m * f / depth
    u, v = float(uv[0, 0]), float(uv[0, 1])
    if u + half_u < 0 or u - half_u > p.size[0] or v + half_v < 0 or v - half_v > p.size[1]:
        return
    sprites = crown_sprites(seed)
    sprite = sprites[int(rng.integers(0, len(sprites)))]
    if rng.random() < 0.5:
        sprite = (sprite[0][:, ::-1], sprite[1][:, ::-1])
    tint = rng.normal(0.0, 6.0, 3) + np.array([0.0, 4.0, 0.0])
    base = (np.array(obj.color_bgr, float) + tint) * (0.35 + 0.65 * p.daylight)
    px_box = (u - half_u, v - half_v, u + half_u, v + half_v)
    lay = p.layers
    haze = (p.haze_bgr, p.vis_m)
    p.later(
        lambda: draw_sprite(
            (lay.color, lay.labels, lay.depth), sprite, px_box, base, label, depth, haze
        )
    )


def _rail(p: _Painter, obj: SceneObject, label: int) -> None:
    col = tuple(float(c) for c in obj.color_bgr)
    for box in _pieces(obj):
        band = _scaled(box, 0.0, 1.0, 1.0, 0.55, 1.0)
        p.box(
            band,
            col,
            label,
            {
                2: [(0, 1, 0.3, 0.6, tuple(0.7 * c for c in col))],
                3: [(0, 1, 0.3, 0.6, tuple(0.7 * c for c in col))],
            },
        )
        if float(np.hypot(*(box.centre[:2] - p.cam_pos[:2]))) > 70.0:
            continue  # posts are sub-pixel there
        n_posts = max(1, int(box.size[0] / 2.0))
        for i in range(n_posts):
            a = (i + 0.5) / n_posts
            post = _scaled(box, a - 0.02, a + 0.02, 0.6, 0.0, 0.6)
            p.box(post, (70.0, 72.0, 75.0), label)


def _pole(p: _Painter, obj: SceneObject, label: int) -> None:
    box = _Box(
        np.array([obj.x_m, obj.y_m, obj.z_m]),
        np.array([obj.length_m, obj.width_m, obj.height_m]),
        obj.yaw_rad,
    )
    col = tuple(float(c) for c in obj.color_bgr)
    if obj.style == "sign":
        p.box(_scaled(box, 0.45, 0.55, 0.06, 0.0, 0.65), (110.0, 110.0, 112.0), label)
        p.box(
            _scaled(box, 0.0, 1.0, 1.0, 0.65, 1.0),
            col,
            label,
            {
                i: [(0.06, 0.94, 0.08, 0.92, col), (0.02, 0.98, 0.02, 0.06, (230.0, 230.0, 230.0))]
                for i in range(4)
            },
        )
    else:
        p.box(box, col, label)


def _building(p: _Painter, obj: SceneObject, label: int, rng: np.random.Generator) -> None:
    col = tuple(float(c) for c in obj.color_bgr)
    win_col = (70.0, 60.0, 55.0) if p.daylight > 0.4 else (120.0, 200.0, 230.0)
    for box in _pieces(obj):
        floors = max(1, int(box.size[2] / 3.2))
        cols = max(1, int(box.size[0] / 2.5))
        wins: list[Detail] = [
            ((i + 0.25) / cols, (i + 0.75) / cols, (j + 0.3) / floors, (j + 0.75) / floors, win_col)
            for i in range(cols)
            for j in range(floors)
            if rng.random() > 0.15
        ]
        details = {2: wins, 3: wins}
        p.box(box, col, label, details)


def draw_objects(
    camera: CameraModel,
    objects: tuple[SceneObject, ...],
    daylight: float,
    world_seed: int,
    haze_bgr: tuple[float, float, float] = (205.0, 200.0, 196.0),
    vis_m: float = float("inf"),
) -> Layers:
    """Draw ``objects`` into fresh full-frame layers, far to near, seen through the haze.

    Every polygon (and tree crown) has one depth, so the haze is applied to its colour once
    rather than per pixel.

    Args:
        camera: The camera.
        objects: Scene objects in the vehicle frame.
        daylight: Daylight level 0..1 (dims faces, lights tail lights at night).
        world_seed: World seed (shape details are seeded per object from it).
        haze_bgr: Airlight colour, BGR grey levels.
        vis_m: Meteorological visibility, metres (inf: no haze).
    """
    h, w = camera.height, camera.width
    layers = Layers(
        np.zeros((h, w, 3), np.uint8),
        np.zeros((h, w), np.uint8),
        np.zeros((h, w), np.float32),
        np.zeros(((h + 1) // 2, (w + 1) // 2), np.float32),
        [],
    )
    painter = _Painter(camera, layers, daylight, haze_bgr, vis_m)
    cam = camera.extrinsics.position
    order = sorted(objects, key=lambda o: -float(np.hypot(o.x_m - cam[0], o.y_m - cam[1])))
    for obj in order:
        if obj.x_m + 0.5 * max(obj.length_m, obj.width_m) < cam[0] + _NEAR_M:
            continue
        label = LEAF_IDS.get(obj.kind, LEAF_IDS["building_wall_fence"])
        rng = np.random.default_rng([world_seed, _seed(obj)])
        if obj.kind == "vehicle":
            _vehicle(painter, obj, label)
        elif obj.kind == "vegetation":
            _tree(painter, obj, label, rng, world_seed)
        elif obj.style in {"guard_rail", "rail", "barrier"}:
            _rail(painter, obj, label)
        elif obj.kind == "pole_sign_utility":
            _pole(painter, obj, label)
        elif obj.style == "building":
            _building(painter, obj, label, rng)
        else:
            col = tuple(float(c) for c in obj.color_bgr)
            for box in _pieces(obj):
                painter.box(box, col, label)
    painter.flush()
    return layers


def shadow_factor(shadow: F32, row0: int, shape: tuple[int, int], strength: float) -> F32:
    """Return the ground light factor on the half grid of rows ``row0:`` (every second pixel).

    Args:
        shadow: Half-resolution shadow layer (darkness 0..1).
        row0: First image row of the ground.
        shape: Shape of the half grid of the ground rows.
        strength: Darkness of a full shadow 0..1.
    """
    import cv2

    blurred = cv2.GaussianBlur(shadow, (0, 0), 1.0)
    part = blurred[row0 // 2 : row0 // 2 + shape[0], : shape[1]]
    factor = np.ones(shape, np.float32)
    factor[: part.shape[0], : part.shape[1]] -= np.float32(strength) * part
    return factor
