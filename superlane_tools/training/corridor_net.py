"""Ego-corridor network (corridor paper, section III): grayscale in, per-pixel probability out.

Fully convolutional; the output has the input's size (652x360 by default). Under 1 M
parameters. The paper's network keeps stride one throughout on a GPU; to meet the 30 ms budget on
two CPU cores this one downsamples to 1/16 with depthwise-separable blocks (context of the whole
lane width), joins the 1/8 and 1/4 skips, and upsamples the logits bilinearly: the corridor is a
large smooth region, so 1/4-resolution logits lose little.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from torch import nn

from superlane_tools.training._blocks import ConvBNReLU, DSConv, UpJoin


@dataclass(frozen=True)
class CorridorNetConfig:
    """Widths of the corridor network.

    Attributes:
        widths: Channels at 1/2, 1/4, 1/8 and 1/16 of the input size.
        decoder: Channels of the decoder joins at 1/8 and 1/4, and of the refinement block.
    """

    widths: tuple[int, int, int, int] = (16, 48, 96, 192)
    decoder: tuple[int, int, int] = (96, 64, 32)


class EgoCorridorNet(nn.Module):
    """Fully convolutional ego-corridor network.

    ``forward`` takes a normalised ``(N, 1, H, W)`` grayscale batch and returns ``(N, 1, H, W)``
    ego-corridor probabilities in ``[0, 1]`` (a sigmoid is part of the graph).
    """

    def __init__(self, config: CorridorNetConfig | None = None) -> None:
        super().__init__()
        cfg = config or CorridorNetConfig()
        w1, w2, w3, w4 = cfg.widths
        d3, d2, d1 = cfg.decoder
        self.stem = ConvBNReLU(1, w1, stride=2)
        self.enc2 = nn.Sequential(DSConv(w1, w2, stride=2), DSConv(w2, w2))
        self.enc3 = nn.Sequential(DSConv(w2, w3, stride=2), DSConv(w3, w3))
        self.enc4 = nn.Sequential(DSConv(w3, w4, stride=2), DSConv(w4, w4), DSConv(w4, w4))
        self.up3 = UpJoin(w4, w3, d3)
        self.up2 = UpJoin(d3, w2, d2)
        self.refine = DSConv(d2, d1)
        self.classifier = nn.Conv2d(d1, 1, 1)

    def logits(self, image: torch.Tensor) -> torch.Tensor:
        """Return the ``(N, 1, H, W)`` pre-sigmoid logits (what the training loss uses)."""
        s1 = self.stem(image)
        s2 = self.enc2(s1)
        s3 = self.enc3(s2)
        s4 = self.enc4(s3)
        x = self.refine(self.up2(self.up3(s4, s3), s2))
        return F.interpolate(
            self.classifier(x), size=image.shape[-2:], mode="bilinear", align_corners=False
        )

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """Return the ``(N, 1, H, W)`` ego-corridor probability."""
        return torch.sigmoid(self.logits(image))
