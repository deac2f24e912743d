"""Training losses: per-head cross-entropy, lane-marking Dice, corridor BCE + Dice."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)

from superlane_tools.scene.adapters.heads import HEADS, IGNORE, Head

_EPS = 1.0


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


def soft_dice_loss(
    prob: torch.Tensor, target: torch.Tensor, valid: torch.Tensor | None = None
) -> torch.Tensor:
    """Return ``1 - soft Dice`` of probabilities against a ``{0, 1}`` target, pooled over the batch.

    Dice is insensitive to how rare the positive class is, which is what thin structures (lane
    markings a few pixels wide, 1-3 % of the image) need on top of cross-entropy.

    Args:
        prob: Probabilities in ``[0, 1]``, any shape.
        target: Float ``{0, 1}`` target of the same shape.
        valid: Optional boolean mask of the pixels that count.
    """
    if valid is not None:
        prob, target = prob[valid], target[valid]
    inter = (prob * target).sum()
    return 1.0 - (2.0 * inter + _EPS) / (prob.sum() + target.sum() + _EPS)


def _index(head: Head, cls: str) -> int:
    return head.classes.index(cls)


def marking_probability(logits: Sequence[torch.Tensor]) -> torch.Tensor:
    """Return ``P(lane_marking)`` per pixel: the product of the softmaxes down the tree.

    ``P(support) * P(drivable | support) * P(lane_marking | drivable)`` from the root, support
    and drivable heads (:data:`HEADS` order), shape ``(N, H, W)``.
    """
    root, _, support, drivable = HEADS[0], HEADS[1], HEADS[2], HEADS[3]
    p = torch.softmax(logits[0], dim=1)[:, _index(root, "support")]
    p = p * torch.softmax(logits[2], dim=1)[:, _index(support, "drivable")]
    return p * torch.softmax(logits[3], dim=1)[:, _index(drivable, "lane_marking")]


def marking_targets(targets: Sequence[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
    """Return ``(is_marking float, known bool)`` from the per-head targets (:data:`HEADS` order).

    A pixel is known when the drivable head has a target there (marking or not) or when a coarser
    head says it is not drivable; a dataset whose drivable pixels stop at ``drivable`` (Cityscapes'
    road includes its markings) leaves them unknown.
    """
    root, _, support, drivable = HEADS[0], HEADS[1], HEADS[2], HEADS[3]
    t_root, t_support, t_drivable = targets[0], targets[2], targets[3]
    not_drivable = ((t_root != IGNORE) & (t_root != _index(root, "support"))) | (
        (t_support != IGNORE) & (t_support != _index(support, "drivable"))
    )
    known = (t_drivable != IGNORE) | not_drivable
    return (t_drivable == _index(drivable, "lane_marking")).float(), known


def banded_dice_loss(
    prob: torch.Tensor, target: torch.Tensor, valid: torch.Tensor, bands: int
) -> torch.Tensor:
    """Return the mean soft-Dice loss over ``bands`` horizontal bands of ``(N, H, W)`` maps.

    Far lane markings are a few pixels wide and sit in the upper rows; a Dice pooled over the
    whole image is dominated by the wide near markings. One Dice per band of rows (bands without
    a marking pixel skipped) gives the far field the same say as the near field.
    """
    height = prob.shape[-2]
    edges = [round(i * height / bands) for i in range(bands + 1)]
    losses = []
    for top, bottom in itertools.pairwise(edges):
        t, v = target[..., top:bottom, :], valid[..., top:bottom, :]
        if bool(t[v].any()):
            losses.append(soft_dice_loss(prob[..., top:bottom, :], t, v))
    if not losses:
        return prob.new_zeros(())
    return torch.stack(losses).mean()


def segmentation_loss(
    logits: Sequence[torch.Tensor],
    targets: Sequence[torch.Tensor],
    weights: Sequence[float],
    class_weights: Sequence[torch.Tensor | None] = (),
    marking_dice: float = 0.0,
    dice_bands: int = 1,
) -> torch.Tensor:
    """Return :func:`hierarchical_loss` plus ``marking_dice`` x the Dice loss of lane markings.

    The Dice term acts on :func:`marking_probability`, so it trains the three heads whose
    decisions a marking pixel has to survive (support, drivable, lane_marking vs road);
    ``dice_bands > 1`` averages it over horizontal bands (:func:`banded_dice_loss`).
    """
    loss = hierarchical_loss(logits, targets, weights, class_weights)
    if marking_dice > 0:
        target, known = marking_targets(targets)
        if bool(target[known].any()):
            prob = marking_probability(logits)
            loss = loss + marking_dice * banded_dice_loss(prob, target, known, max(1, dice_bands))
    return loss


def corridor_loss(
    logits: torch.Tensor,
    target: torch.Tensor,
    dice: float = 0.0,
    valid: torch.Tensor | None = None,
    rmse: bool = False,
) -> torch.Tensor:
    """Return BCE (+ ``dice`` x soft Dice) between corridor logits and a ``{0, 1}`` float mask.

    The corridor paper trains with RMSE on probabilities (``rmse=True``); BCE on logits
    converges faster from few frames and reaches the same fixed point (the per-pixel
    probability). The Dice term rewards the overlap of the whole region (what corridor IoU
    measures). ``valid`` masks pixels whose target is unknown (rows above a real label's ego
    lane); they contribute nothing.
    """
    mask = torch.ones_like(target, dtype=torch.bool) if valid is None else valid
    if not bool(mask.any()):
        return logits.new_zeros(()) + 0.0 * logits.sum()
    if rmse:
        loss = torch.sqrt(((torch.sigmoid(logits) - target) ** 2)[mask].mean() + 1e-8)
    else:
        loss = F.binary_cross_entropy_with_logits(logits[mask], target[mask])
    if dice > 0:
        loss = loss + dice * soft_dice_loss(torch.sigmoid(logits), target, mask)
    return loss
