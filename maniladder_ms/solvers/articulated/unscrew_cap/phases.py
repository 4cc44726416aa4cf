"""Solver phases shared by the UnscrewCap family (tasks/articulated/unscrew_cap/): the twisting hand's way above
the lid with its wrist wound up. The twist strokes themselves are `solvers.twist.unscrew` (a library module)."""

from __future__ import annotations

import torch

from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import rise_first, wind_up_target

CLEARANCE = 0.1  # m above the lid top where the twisting hand winds its wrist up (its approach passes high over it)
WIND_UP_STEPS = 80  # the LEAP hands: at most this many control steps to get above the lid with the wrist wound up
# the LEAP power grasp turns the lid by ~0.8 of the wrist's turn (the fingers slip; 4.4 rad for 5.5 rad of joint 7
# on UnscrewCapHand's seed 104): the open hand turns back for the rest of the turn over this, a margin below it
FOLLOW = 0.7


def wind_up_above_lid(s: DrivenSolver, task, arm: str, offset=None):
    """This control step's target (p, q) of the twisting `arm`: its grip point (`offset`, TCP frame) `CLEARANCE`
    above the lid's top, reached rising first (`twist.rise_first`: the rest pose's hand is level with or below the
    lid top), its wrist winding up meanwhile (`twist.wind_up_target`); call it each step."""
    above = rise_first(s, arm, task.lid_top() + torch.tensor([0.0, 0.0, CLEARANCE], device=task.device))
    return wind_up_target(s, arm, above, offset)
