"""Ego-corridor network (corridor paper, section III): grayscale in, per-pixel probability out.

Fully convolutional; the output has the input's size (652x360 by default). Under 1 M
parameters. The paper's network keeps stride one throughout on a GPU; to meet the 30 ms budget on
two CPU cores this one optionally average-pools the input (``pool``), downsamples to 1/16 with
depthwise-separable blocks (context of the whole lane width), joins the 1/8 and 1/4 skips, and
upsamples the logits bilinearly: the corridor is a large smooth region, so coarse logits lose
little. Which lane is the *ego* lane depends on where it lies in the image, which a fully
convolutional network cannot see; ``coords`` appends a horizontal-position channel (-1 at the
left edge, +1 at the right) to the input, so the network can tell the ego lane from its
neighbours (train on full frames then: a random crop would move the origin).
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
        pool: Average-pool the input by this factor first (1 = full resolution).
        coords: Append a horizontal-position channel to the input.
    """

    widths: tuple[int, int, int, int] = (16, 48, 96, 192)
    decoder: tuple[int, int, int] = (96, 64, 32)
    pool: int = 2
    coords: bool = True


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
        self.pool = max(1, cfg.pool)
        self.coords = cfg.coords
        self.stem = ConvBNReLU(2 if cfg.coords else 1, w1, stride=2)
        self.enc2 = nn.Sequential(DSConv(w1, w2, stride=2), DSConv(w2, w2))
        self.enc3 = nn.Sequential(DSConv(w2, w3, stride=2), DSConv(w3, w3))
        self.enc4 = nn.Sequential(DSConv(w3, w4, stride=2), DSConv(w4, w4), DSConv(w4, w4))
        self.up3 = UpJoin(w4, w3, d3)
        self.up2 = UpJoin(d3, w2, d2)
        self.refine = DSConv(d2, d1)
        self.classifier = nn.Conv2d(d1, 1, 1)

    def logits(self, image: torch.Tensor) -> torch.Tensor:
        """Return the ``(N, 1, H, W)`` pre-sigmoid logits (what the training loss uses)."""
        x = F.avg_pool2d(image, self.pool) if self.pool > 1 else image
        if self.coords:
            # cumsum of ones keeps the graph float32 in ONNX (linspace exports as double)
            width = x.shape[-1]
            xs = torch.ones_like(x[:, :1, :1, :]).cumsum(-1)
            xs = (xs - 1.0) * (2.0 / max(1, width - 1)) - 1.0
            x = torch.cat([x, xs.expand(-1, -1, x.shape[-2], -1)], 1)
        s1 = self.stem(x)
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


class PaperCorridorNet(nn.Module):
    """The corridor paper's own network (section III-B): symmetric, stride one throughout.

    Convolutions and max-pooling keep stride one (pooling windows of 3, 5, 7 and 9 pixels widen
    the context without shrinking the map); the decoder mirrors the encoder with a transposed
    convolution per convolution, so the output keeps the 652x360 input size. ReLU activations, a
    sigmoid output, about 0.59 M parameters with the default widths (the paper: 41 layers,
    about 0.66 M). It is far slower on a CPU than :class:`EgoCorridorNet` (every layer runs at full
    resolution); it exists for the ablation the card reports.
    """

    def __init__(self, widths: tuple[int, int, int, int] = (16, 32, 64, 128)) -> None:
        super().__init__()
        self.pool = 1
        self.coords = False
        pools = (3, 5, 7, 9)
        enc: list[nn.Module] = []
        c_in = 1
        for width, k in zip(widths, pools, strict=True):
            enc += [nn.Conv2d(c_in, width, 3, 1, 1), nn.ReLU(inplace=True)]
            enc += [nn.Conv2d(width, width, 3, 1, 1), nn.ReLU(inplace=True)]
            enc += [nn.MaxPool2d(k, 1, k // 2)]
            c_in = width
        dec: list[nn.Module] = []
        outs = (*reversed(widths[:-1]), widths[0])
        for width, c_out in zip(reversed(widths), outs, strict=True):
            dec += [nn.ConvTranspose2d(width, width, 3, 1, 1), nn.ReLU(inplace=True)]
            dec += [nn.ConvTranspose2d(width, c_out, 3, 1, 1), nn.ReLU(inplace=True)]
        self.encoder = nn.Sequential(*enc)
        self.decoder = nn.Sequential(*dec)
        self.classifier = nn.Conv2d(widths[0], 1, 1)

    def logits(self, image: torch.Tensor) -> torch.Tensor:
        """Return the ``(N, 1, H, W)`` pre-sigmoid logits."""
        out: torch.Tensor = self.classifier(self.decoder(self.encoder(image)))
        return out

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """Return the ``(N, 1, H, W)`` ego-corridor probability."""
        return torch.sigmoid(self.logits(image))
