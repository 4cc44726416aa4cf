"""What the FlattenClay family's solvers share."""

from __future__ import annotations

import torch

from maniladder_ms.tasks.clay.flatten_clay.base import FlattenClayTask


def flat_with_margin(task: FlattenClayTask, info: dict, height_margin: float, area_margin: float) -> torch.Tensor:
    """[B] bool: the clay is `height_margin` below the height rule and `area_margin` above the footprint rule
    (in ratios to the start): a solver stops flattening there, the clay springing back by up to a yield
    distance per link once the tool is out of it."""
    return (info["height_ratio"] <= task.max_height_ratio - height_margin) & (
        info["area_ratio"] >= task.min_area_ratio + area_margin)
