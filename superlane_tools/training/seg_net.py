"""Hierarchical segmentation network: light separable encoder-decoder, one head per parent.

The encoder downsamples to 1/32 with depthwise-separable blocks (context from depth rather than
dilation: dilated depthwise convolutions train very slowly on CPU), the decoder joins skips at
1/16, 1/8, 1/4 and 1/2, and a 1x1 convolution produces the logits of every head at once, split
per head and upsampled bilinearly to the input size. The exported graph
(:class:`HalfResolutionHeads`) stops before the upsampling, which the runtime does. Heads follow
:data:`superlane_tools.scene.adapters.heads.HEADS` (SUPER Fig. 3): one softmax per parent node.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from torch import nn

from superlane_tools.scene.adapters.heads import HEADS
from superlane_tools.training._blocks import ConvBNReLU, DSConv, UpJoin


@dataclass(frozen=True)
class SegNetConfig:
    """Widths of the segmentation network.

    Attributes:
        widths: Channels at 1/2, 1/4, 1/8, 1/16 and 1/32 of the input size.
        decoder: Channels of the decoder at 1/16, 1/8, 1/4 and 1/2.
    """

    widths: tuple[int, int, int, int, int] = (24, 48, 96, 160, 256)
    decoder: tuple[int, int, int, int] = (128, 96, 64, 32)


class HierarchicalSegNet(nn.Module):
    """Encoder-decoder with one logit head per hierarchy parent node.

    ``forward`` takes a normalised ``(N, 3, H, W)`` RGB batch and returns one ``(N, C_k, H, W)``
    logit tensor per head, in :data:`HEADS` order.
    """

    def __init__(self, config: SegNetConfig | None = None) -> None:
        super().__init__()
        cfg = config or SegNetConfig()
        w1, w2, w3, w4, w5 = cfg.widths
        d4, d3, d2, d1 = cfg.decoder
        self.stem = ConvBNReLU(3, w1, stride=2)
        self.enc2 = nn.Sequential(DSConv(w1, w2, stride=2), DSConv(w2, w2))
        self.enc3 = nn.Sequential(DSConv(w2, w3, stride=2), DSConv(w3, w3))
        self.enc4 = nn.Sequential(DSConv(w3, w4, stride=2), DSConv(w4, w4))
        self.enc5 = nn.Sequential(DSConv(w4, w5, stride=2), DSConv(w5, w5), DSConv(w5, w5))
        self.up4 = UpJoin(w5, w4, d4)
        self.up3 = UpJoin(d4, w3, d3)
        self.up2 = UpJoin(d3, w2, d2)
        self.up1 = UpJoin(d2, w1, d1)
        self.head_sizes = tuple(len(h.classes) for h in HEADS)
        self.classifier = nn.Conv2d(d1, sum(self.head_sizes), 1)

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at the input resolution."""
        logits = F.interpolate(
            self.classifier_logits(image),
            size=image.shape[-2:],
            mode="bilinear",
            align_corners=False,
        )
        return tuple(torch.split(logits, list(self.head_sizes), dim=1))

    def classifier_logits(self, image: torch.Tensor) -> torch.Tensor:
        """Return every head's logits at once, at half the input resolution (before upsampling)."""
        s1 = self.stem(image)
        s2 = self.enc2(s1)
        s3 = self.enc3(s2)
        s4 = self.enc4(s3)
        s5 = self.enc5(s4)
        x = self.up1(self.up2(self.up3(self.up4(s5, s4), s3), s2), s1)
        out: torch.Tensor = self.classifier(x)
        return out


class HalfResolutionHeads(nn.Module):
    """What is exported to ONNX: the per-head logits at half resolution, not upsampled.

    The runtime upsamples them bilinearly to the input size
    (:func:`superlane_tools.scene.onnx_backend.upsample_scores`), the same interpolation as
    :meth:`HierarchicalSegNet.forward`, several times cheaper than onnxruntime's ``Resize`` on
    one CPU thread (docs/models.md, "Output resolution").
    """

    def __init__(self, net: HierarchicalSegNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at half the input resolution."""
        logits = self.net.classifier_logits(image)
        return tuple(torch.split(logits, list(self.net.head_sizes), dim=1))
