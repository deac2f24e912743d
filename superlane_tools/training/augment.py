"""Augmentation for real camera images: geometry (scale, crop, pitch and roll, flip) and photometry.

Geometry is one affine resampling per frame (``grid_sample``): zoom ``s``, roll (rotation about the
image centre), pitch (a vertical shift of the horizon: for small angles a pitch change moves the
image rows by ``f * d_pitch``), a crop position and an optional mirror. Images are sampled
bilinearly, labels nearest-neighbour; pixels from outside the frame become void / unknown.
Photometry acts on the batch: gain, contrast, colour cast, gamma, a cast shadow (a dark band
between two random lines), blur, JPEG re-encoding and sensor noise. Every draw comes from one
seeded generator, so a run is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from numpy.typing import NDArray

from superlane_tools.training.data import _blur


@dataclass(frozen=True)
class RealAugment:
    """Augmentation strengths (0 or 1.0 scale factors switch parts off).

    Attributes:
        scale: Zoom range ``(min, max)`` (1 = training size).
        roll_deg: Max roll, degrees.
        pitch_frac: Max horizon shift as a fraction of the image height (small pitch change).
        flip_prob: Probability of a horizontal mirror.
        brightness: Max relative gain change.
        contrast: Max relative contrast change.
        channel_gain: Max per-channel gain change (colour cast).
        gamma: Max relative gamma change.
        shadow_prob: Probability of a cast shadow band.
        blur_prob: Probability of a Gaussian blur (sigma 0.5-1.5 px).
        jpeg_prob: Probability of JPEG re-encoding (quality 25-90).
        noise_std: Max standard deviation of Gaussian noise on the [0, 1] scale.
    """

    scale: tuple[float, float] = (0.85, 1.25)
    roll_deg: float = 3.0
    pitch_frac: float = 0.04
    flip_prob: float = 0.5
    brightness: float = 0.35
    contrast: float = 0.35
    channel_gain: float = 0.1
    gamma: float = 0.3
    shadow_prob: float = 0.35
    blur_prob: float = 0.25
    jpeg_prob: float = 0.3
    noise_std: float = 0.03


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
    s, roll, pitch, flip = 1.0, 0.0, 0.0, False
    if params is not None:
        s = _u(gen, *params.scale)
        roll = math.radians(_u(gen, -params.roll_deg, params.roll_deg))
        pitch = _u(gen, -params.pitch_frac, params.pitch_frac) * h_in
        flip = float(torch.rand((), generator=gen)) < params.flip_prob
    half_w, half_h = w_out / (2 * s), h_out / (2 * s)
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
        [mirror * cos * w_out / (w_in * s), -sin * h_out / (w_in * s), 2 * cx / w_in - 1],
        [mirror * sin * w_out / (h_in * s), cos * h_out / (h_in * s), 2 * cy / h_in - 1],
    ]
    return torch.tensor(theta, dtype=torch.float32)


def warp(
    image: torch.Tensor,
    target: torch.Tensor,
    theta: torch.Tensor,
    out_size: tuple[int, int],
    outside: int,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Resample a ``(C, H, W)`` image (bilinear) and an ``(H, W)`` target (nearest).

    Target pixels that come from outside the source frame get ``outside``.
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
    noise = uniform(n, 1, 1, 1, low=0.0, high=params.noise_std)
    out = out + noise * torch.randn(out.shape, generator=gen)
    return out.clamp(0.0, 1.0)
