"""Training losses: weighted per-head cross-entropy for heterogeneous labels, corridor BCE."""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)

from superlane_tools.scene.adapters.heads import IGNORE


def hierarchical_loss(
    logits: Sequence[torch.Tensor],
    targets: Sequence[torch.Tensor],
    weights: Sequence[float],
    class_weights: Sequence[torch.Tensor | None] = (),
) -> torch.Tensor:
    """Return the weighted sum of per-head softmax cross-entropies (SUPER II-C).

    Each head averages over the pixels it is trained on; pixels whose target is ``IGNORE`` (the
    dataset does not label that level there, or the pixel is not below the head's parent) do not
    count. A head with no labelled pixel in the batch contributes zero.

    Args:
        logits: One ``(N, C_k, H, W)`` tensor per head.
        targets: One ``(N, H, W)`` ``int64`` tensor per head.
        weights: One weight per head.
        class_weights: Optional per-head class weights (against rare classes such as markings).

    Returns:
        The scalar loss.
    """
    per_class = list(class_weights) or [None] * len(logits)
    total = logits[0].new_zeros(())
    for head_logits, target, weight, cw in zip(logits, targets, weights, per_class, strict=True):
        if not bool((target != IGNORE).any()):
            continue
        ce = F.cross_entropy(head_logits, target, weight=cw, ignore_index=IGNORE)
        total = total + weight * ce
    return total


def corridor_loss(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Return the binary cross-entropy between corridor logits and a ``{0, 1}`` float mask.

    The corridor paper trains with RMSE on probabilities; BCE on logits converges faster from
    few synthetic frames and reaches the same fixed point (the per-pixel probability).
    """
    return F.binary_cross_entropy_with_logits(logits, target)
