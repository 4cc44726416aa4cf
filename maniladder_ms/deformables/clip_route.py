"""A cable routed through a row of clips in sequence (RouteCableClipsHand): where the clips of a straight row
stand, and the episode's record of the order in which the cable went into them.

- `row_centres`: the centres of `count` clips spaced evenly along a line on the table;
- `enter_in_order`: one control step's update of the per-clip "entered" record: a clip counts as entered when the
  cable lies seated in it while the hand presses it and every clip before it has been entered; a clip seated
  before the one ahead of it was entered breaks the order for the rest of the episode.
"""

from __future__ import annotations

import torch


def row_centres(middle: torch.Tensor, yaw: torch.Tensor, spacing: float, count: int) -> torch.Tensor:
    """Centres [B, count, 2] of `count` clips `spacing` apart along the line through `middle` [B, 2] at world yaw
    `yaw` [B]; clip 0 lies at the line's -yaw end (the row runs from it along +yaw), the row's middle at `middle`."""
    offsets = (torch.arange(count, dtype=middle.dtype, device=middle.device) - (count - 1) / 2) * spacing
    along = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
    return middle[:, None, :2] + offsets[None, :, None] * along[:, None, :]


def enter_in_order(entered: torch.Tensor, broken: torch.Tensor, seated: torch.Tensor,
                   pressing: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """One step of the clips' order record, batched: `entered` [B, n] bool (clip i entered so far), `broken` [B]
    bool (the order was broken so far), `seated` [B, n] bool (the cable lies in clip i now), `pressing` [B] bool
    (the hand touches the cable now). Clip i becomes entered when it is seated while the hand presses and clips
    0..i-1 are entered (the record before this step); the order breaks when a clip is seated while the one before
    it is not entered. Returns the updated (entered, broken)."""
    before = torch.cat([torch.ones_like(entered[:, :1]), entered[:, :-1]], dim=1)  # clips ahead all entered
    ahead_entered = torch.cumprod(before.int(), dim=1).bool()
    broken = broken | (seated & ~ahead_entered).any(dim=1)
    newly = seated & pressing[:, None] & ahead_entered
    # clips entered in one step go one at a time: clip i needs clip i-1 entered before this step
    return entered | newly, broken
