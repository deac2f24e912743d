"""Shared torch building blocks: depthwise-separable convolutions and upsampling joins."""

from __future__ import annotations

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from torch import nn


class ConvBNReLU(nn.Sequential):
    """A dense ``k x k`` convolution, batch norm and ReLU."""

    def __init__(self, c_in: int, c_out: int, stride: int = 1, kernel: int = 3) -> None:
        super().__init__(
            nn.Conv2d(c_in, c_out, kernel, stride, kernel // 2, bias=False),
            nn.BatchNorm2d(c_out),
            nn.ReLU(inplace=True),
        )


class DSConv(nn.Sequential):
    """Depthwise-separable block: depthwise 3x3 (stride, dilation) then pointwise 1x1.

    Args:
        c_in: Input channels.
        c_out: Output channels.
        stride: Stride of the depthwise convolution (1 or 2).
        dilation: Dilation of the depthwise convolution (context without downsampling).
    """

    def __init__(self, c_in: int, c_out: int, stride: int = 1, dilation: int = 1) -> None:
        super().__init__(
            nn.Conv2d(c_in, c_in, 3, stride, dilation, dilation, groups=c_in, bias=False),
            nn.BatchNorm2d(c_in),
            nn.ReLU(inplace=True),
            nn.Conv2d(c_in, c_out, 1, bias=False),
            nn.BatchNorm2d(c_out),
            nn.ReLU(inplace=True),
        )


class UpJoin(nn.Module):
    """Upsample a coarse map bilinearly to a skip connection's size, concatenate, fuse."""

    def __init__(self, c_coarse: int, c_skip: int, c_out: int) -> None:
        super().__init__()
        self.fuse = DSConv(c_coarse + c_skip, c_out)

    def forward(self, coarse: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        """Return the fused map at the skip connection's resolution."""
        up = F.interpolate(coarse, size=skip.shape[-2:], mode="bilinear", align_corners=False)
        out: torch.Tensor = self.fuse(torch.cat([up, skip], dim=1))
        return out


def count_parameters(model: nn.Module) -> int:
    """Return the number of trainable parameters of ``model``."""
    return int(sum(p.numel() for p in model.parameters() if p.requires_grad))
