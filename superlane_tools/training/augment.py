"""Augmentation for real camera images: geometry (scale, crop, pitch and roll, flip) and photometry.

Geometry is one affine resampling per frame (``grid_sample``), a change of camera: zoom ``s`` (a
focal-length change), aspect ratio (another sensor or a resized frame: horizontal and vertical
scale differ by a factor ``a``), roll (rotation about the image centre), pitch (a vertical shift
of the horizon: for small angles a pitch change moves the image rows by ``f * d_pitch``), a crop
position (another principal point) and an optional mirror. Images are sampled bilinearly, labels
nearest-neighbour; pixels from outside the frame become void / unknown. A mirrored frame's
labels go through :data:`MIRROR_SWAP`, which swaps every left/right-dependent class of the
hierarchy (none today: marking type and colour do not depend on the side, so the table is the
identity; a class named ``..._left`` / ``..._right`` would be swapped).
Photometry acts on the batch: gain, contrast, colour cast, colour temperature, gamma, a cast
shadow (a dark band between two random lines), blur, dusk / night (strong gamma, low gain, a blue
cast, more noise), JPEG re-encoding and sensor noise. Every draw comes from one seeded
generator, so a run is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from numpy.typing import NDArray

from superlane_tools.scene.adapters.heads import NODE_CODES
from superlane_tools.training.data import _blur


def mirror_swap_table(names: dict[int, str]) -> NDArray[np.uint8]:
    """Return the ``uint8`` code table of a mirror: ``..left..`` <-> ``..right..`` classes swapped.

    Args:
        names: Label code -> class name.
    """
    table = np.arange(256, dtype=np.uint8)
    by_name = {name: code for code, name in names.items()}
    for code, name in names.items():
        for a, b in (("left", "right"), ("right", "left")):
            if a in name and name.replace(a, b) in by_name:
                table[code] = by_name[name.replace(a, b)]
    return table


MIRROR_SWAP = mirror_swap_table({code: name for name, code in NODE_CODES.items()})
"""Node-code table applied to a mirrored frame's labels (identity for today's hierarchy)."""


@dataclass(frozen=True)
class RealAugment:
    """Augmentation strengths (0 or 1.0 scale factors switch parts off).

    Attributes:
        scale: Zoom range ``(min, max)`` (1 = training size): a focal-length change.
        aspect: Range of the ratio of horizontal to vertical scale (1 = unchanged).
        roll_deg: Max roll, degrees.
        pitch_frac: Max horizon shift as a fraction of the image height (small pitch change).
        flip_prob: Probability of a horizontal mirror.
        brightness: Max relative gain change.
        contrast: Max relative contrast change.
        channel_gain: Max per-channel gain change (colour cast).
        temperature: Max colour-temperature shift (red up and blue down, or the reverse).
        gamma: Max relative gamma change.
        shadow_prob: Probability of a cast shadow band.
        blur_prob: Probability of a Gaussian blur (sigma 0.5-1.5 px).
        jpeg_prob: Probability of JPEG re-encoding (quality 25-90).
        noise_std: Max standard deviation of Gaussian noise on the [0, 1] scale.
        night_prob: Probability of a dusk / night frame.
    """

    scale: tuple[float, float] = (0.85, 1.25)
    aspect: tuple[float, float] = (1.0, 1.0)
    roll_deg: float = 3.0
    pitch_frac: float = 0.04
    flip_prob: float = 0.5
    brightness: float = 0.35
    contrast: float = 0.35
    channel_gain: float = 0.1
    temperature: float = 0.0
    gamma: float = 0.3
    shadow_prob: float = 0.35
    blur_prob: float = 0.25
    jpeg_prob: float = 0.3
    noise_std: float = 0.03
    night_prob: float = 0.0


CAMERA_AUGMENT = RealAugment(
    scale=(0.7, 1.45),
    aspect=(0.75, 1.35),
    roll_deg=4.0,
    pitch_frac=0.08,
    temperature=0.12,
    night_prob=0.12,
)
"""Camera-geometry augmentation (one network for many cameras): the ``lite0`` recipe."""
CANONICAL_AUGMENT = RealAugment(
    scale=(0.92, 1.1),
    aspect=(0.95, 1.05),
    roll_deg=1.0,
    pitch_frac=0.04,
    temperature=0.12,
    night_prob=0.12,
)
"""Augmentation for frames in the canonical camera (``--canonical-camera``): the camera's
photometry, and only the geometry that remains once every frame is in one camera: calibration
and estimation error (about 1 degree of pitch or roll, a few per cent of focal length) and the
vehicle's own pitching."""


def _u(gen: torch.Generator, low: float, high: float) -> float:
    return low + (high - low) * float(torch.rand((), generator=gen))


def jpeg(image: NDArray[np.uint8], quality: int) -> NDArray[np.uint8]:
    """Return ``image`` after a JPEG encode/decode round trip at ``quality``."""
    import cv2

    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    assert ok, "JPEG encoding of a uint8 image cannot fail"
    return np.asarray(cv2.imdecode(data, cv2.IMREAD_UNCHANGED), np.uint8).reshape(image.shape)


def affine_theta(
    in_size: tuple[int, int],
    out_size: tuple[int, int],
    params: RealAugment | None,
    gen: torch.Generator,
    random_crop: bool,
) -> torch.Tensor:
    """Return the ``(2, 3)`` ``affine_grid`` matrix of one frame's geometric augmentation.

    Args:
        in_size: Source ``(width, height)`` in pixels.
        out_size: Output ``(width, height)`` in pixels.
        params: Strengths; None = a plain centre crop at scale 1.
        gen: Random generator.
        random_crop: Draw the crop position (segmentation); else keep the frame centred
            (corridor: the horizontal position channel needs the frame's own origin).
    """
    (w_in, h_in), (w_out, h_out) = in_size, out_size
    s, aspect, roll, pitch, flip = 1.0, 1.0, 0.0, 0.0, False
    if params is not None:
        s = _u(gen, *params.scale)
        if params.aspect != (1.0, 1.0):
            aspect = math.exp(_u(gen, math.log(params.aspect[0]), math.log(params.aspect[1])))
        roll = math.radians(_u(gen, -params.roll_deg, params.roll_deg))
        pitch = _u(gen, -params.pitch_frac, params.pitch_frac) * h_in
        flip = float(torch.rand((), generator=gen)) < params.flip_prob
    sx, sy = s * math.sqrt(aspect), s / math.sqrt(aspect)
    half_w, half_h = w_out / (2 * sx), h_out / (2 * sy)
    cx, cy = w_in / 2.0, h_in / 2.0
    if random_crop and params is not None:
        if w_in > 2 * half_w:
            cx = _u(gen, half_w, w_in - half_w)
        if h_in > 2 * half_h:
            cy = _u(gen, half_h, h_in - half_h)
    cy += pitch
    cos, sin = math.cos(roll), math.sin(roll)
    mirror = -1.0 if flip else 1.0
    theta = [
        [mirror * cos * w_out / (w_in * sx), -sin * h_out / (w_in * sy), 2 * cx / w_in - 1],
        [mirror * sin * w_out / (h_in * sx), cos * h_out / (h_in * sy), 2 * cy / h_in - 1],
    ]
    return torch.tensor(theta, dtype=torch.float32)


def is_mirrored(theta: torch.Tensor) -> bool:
    """Return True when the affine map ``theta`` mirrors the frame (negative determinant)."""
    return float(theta[0, 0] * theta[1, 1] - theta[0, 1] * theta[1, 0]) < 0.0


def warp(
    image: torch.Tensor,
    target: torch.Tensor,
    theta: torch.Tensor,
    out_size: tuple[int, int],
    outside: int,
    mirror_swap: NDArray[np.uint8] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Resample a ``(C, H, W)`` image (bilinear) and an ``(H, W)`` target (nearest).

    Target pixels that come from outside the source frame get ``outside``. When ``theta``
    mirrors the frame, target values go through ``mirror_swap`` (a 256-entry table, e.g.
    :data:`MIRROR_SWAP` for node codes).
    """
    shape = (1, image.shape[0], out_size[1], out_size[0])
    grid = F.affine_grid(theta.unsqueeze(0), list(shape), align_corners=False)
    warped = F.grid_sample(
        image.unsqueeze(0), grid, mode="bilinear", padding_mode="reflection", align_corners=False
    )[0]
    shifted = (target.float() + 1.0)[None, None]
    labels = F.grid_sample(shifted, grid, mode="nearest", padding_mode="zeros", align_corners=False)
    labels = labels[0, 0].round().long()
    out = torch.where(labels == 0, torch.full_like(labels, outside), labels - 1)
    if mirror_swap is not None and is_mirrored(theta):
        out = torch.from_numpy(mirror_swap).long()[out.clamp(0, 255)]
    return warped, out


def photometric(images: torch.Tensor, params: RealAugment, gen: torch.Generator) -> torch.Tensor:
    """Return a photometrically augmented ``(N, C, H, W)`` batch in ``[0, 1]``."""
    n, channels, height, width = images.shape

    def uniform(*shape: int, low: float, high: float) -> torch.Tensor:
        return low + (high - low) * torch.rand(*shape, generator=gen)

    out = images.clamp(1e-4, 1.0) ** uniform(
        n, 1, 1, 1, low=1 - params.gamma, high=1 + params.gamma
    )
    gain = uniform(n, 1, 1, 1, low=1 - params.brightness, high=1 + params.brightness)
    if channels == 3:
        gain = gain * uniform(n, 3, 1, 1, low=1 - params.channel_gain, high=1 + params.channel_gain)
        if params.temperature > 0:
            t = uniform(n, 1, 1, 1, low=-params.temperature, high=params.temperature)
            gain = gain * torch.cat([1 + t, torch.ones_like(t), 1 - t], dim=1)
    out = out * gain
    mean = out.mean(dim=(1, 2, 3), keepdim=True)
    out = (out - mean) * uniform(
        n, 1, 1, 1, low=1 - params.contrast, high=1 + params.contrast
    ) + mean
    ys = torch.linspace(-1.0, 1.0, height).view(height, 1)
    xs = torch.linspace(-1.0, 1.0, width).view(1, width)
    for i in range(n):
        if float(torch.rand((), generator=gen)) < params.shadow_prob:
            # a band between two roughly parallel random lines, darkened
            angle = _u(gen, 0.0, math.pi)
            normal_x, normal_y = math.cos(angle), math.sin(angle)
            offset, band = _u(gen, -0.8, 0.8), _u(gen, 0.1, 0.6)
            d = normal_x * xs + normal_y * ys - offset
            mask = ((d > 0) & (d < band)).float()
            mask = _blur(mask[None, None], 2.0)[0]
            out[i] = out[i] * (1.0 - mask * _u(gen, 0.25, 0.6))
        if float(torch.rand((), generator=gen)) < params.blur_prob:
            out[i : i + 1] = _blur(out[i : i + 1], _u(gen, 0.5, 1.5))
        if params.night_prob > 0 and float(torch.rand((), generator=gen)) < params.night_prob:
            out[i] = night(out[i], _u(gen, 0.0, 1.0), gen)
    noise = uniform(n, 1, 1, 1, low=0.0, high=params.noise_std)
    out = out.clamp(0.0, 1.0)
    out = out + noise * torch.randn(out.shape, generator=gen)
    return out.clamp(0.0, 1.0)


def night(image: torch.Tensor, depth: float, gen: torch.Generator) -> torch.Tensor:
    """Return a ``(C, H, W)`` ``[0, 1]`` frame as at dusk (``depth`` 0) or at night (1).

    A gamma of 1.5-2.7 darkens the shadows more than the lights (street lights, reflections of
    markings stay visible), the gain drops to 0.75-0.35, a blue cast (colour frames) and sensor
    noise that grows with the darkness.
    """
    gamma = 1.5 + 1.2 * depth
    out = image.clamp(1e-4, 1.0) ** gamma * (0.75 - 0.4 * depth)
    if image.shape[0] == 3:
        out = out * torch.tensor([0.85, 0.95, 1.1]).view(3, 1, 1)
    out = out + (0.01 + 0.02 * depth) * torch.randn(out.shape, generator=gen)
    return out.clamp(0.0, 1.0)
