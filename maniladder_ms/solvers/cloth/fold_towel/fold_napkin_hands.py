"""Scripted solver of FoldNapkinHands (tasks/cloth/fold_towel/fold_napkin_hands.py): the left hand pins its corner
while the right carries the opposite corner over the napkin and lays it on the pinned one.

1. Pinch: each hand scissor-pinches the corner on its side (`solvers.towel.pinch_side_corners`, as
   LiftTowelHands).
2. Lift: the right hand lifts its corner `LIFT` while the left holds its corner on the table; the left opens.
3. Carry: the right carries its corner in an arc (`ARC_HEIGHT` over the middle) to `HOVER` above the left's
   corner in `CARRY_STEPS`, while the left clears the way (`CLEAR`, in the first `CLEAR_SHARE` of the steps).
4. Lay: the right lowers its corner to `RELEASE_ABOVE` over its partner, aimed from where the corner hangs in
   the pinch (read again `LAY_CORRECTIONS` times).
5. Release: open and rise.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import follow_paths, glide
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.towel import pinch_side_corners
from maniladder_ms.tasks.cloth.fold_towel.fold_napkin_hands import FoldNapkinHandsEnv

LIFT = 0.04  # the carried corner first rises this high (the other hand pins its corner meanwhile)
ARC_HEIGHT = 0.12  # then passes over the napkin's middle this high
CARRY_STEPS = 50  # control steps of the arc, from the lift to above the partner corner
HOVER = 0.04  # the arc ends this high above the partner corner
RELEASE_ABOVE = 0.02  # the carried corner is let go this high above its partner: one layer's thickness
LAY_STEP = 0.004  # metres a control step while laying the corner down
LAY_CORRECTIONS = 2  # times the lay target is read again from where the corner hangs
# the pinning hand lets go as the carry starts and clears the carrying hand's way: forwards, out and up by this
# (left in place, or lifted 22 cm back towards the robot, the right forearm (Panda link 5) ran into the left palm
# and stopped the carry 6-9 cm short on seed 100)
CLEAR = (0.15, 0.15, 0.08)
CLEAR_SHARE = 0.5  # of the carry's steps


@register_solver("FoldNapkinHands", control_modes=TCP_DELTA_MODES)
def solve_fold_napkin_hands(env, seed: int) -> dict:
    """The phases of the module docstring: the left hand pins, the right carries."""
    with DrivenSolver.episode(env, seed) as s:
        task: FoldNapkinHandsEnv = env.unwrapped
        device = task.device
        grasps = pinch_side_corners(s, task.towel, task.hand_corners)
        pin, carry = grasps["left"], grasps["right"]
        carried, partner = task.hand_corners["right"], task.hand_corners["left"]
        up = lambda h: torch.tensor([0.0, 0.0, h], device=device)  # noqa: E731
        lifted = carry.p + up(LIFT)
        glide(s, {carry.arm: (carry.p, lifted, carry.q)}, settle_steps=0)
        s.set_ee(pin.ee, "scissor_open", steps=3)
        # the TCP keeps its offset to the pinched particle: it goes where the particle should go
        start = task.towel.positions()[:, carried]
        hover = carry.p + (task.towel.positions()[:, partner] + up(HOVER) - start)
        pin_from = s.tcp(pin.arm).p.clone()
        pin_to = pin_from + torch.tensor(CLEAR, device=device)

        def arc(t: float) -> torch.Tensor:
            return lifted + (hover - lifted) * t + up(ARC_HEIGHT - LIFT) * 4 * t * (1 - t)

        def clear(t: float) -> torch.Tensor:
            return pin_from + (pin_to - pin_from) * min(1.0, t / CLEAR_SHARE)

        follow_paths(s, {carry.arm: (arc, carry.q), pin.arm: (clear, pin.q)}, CARRY_STEPS)
        # lay the corner onto its partner, the TCP aimed by where the corner hangs in the pinch now (the sheet
        # hanging from it drags it a few cm back through the fingers during the carry)
        for _ in range(LAY_CORRECTIONS):
            points = task.towel.positions()
            lay = s.tcp(carry.arm).p + (points[:, partner] + up(RELEASE_ABOVE) - points[:, carried])
            glide(s, {carry.arm: (s.tcp(carry.arm).p.clone(), lay, carry.q)}, step_length=LAY_STEP, settle_steps=5)
        s.set_ee(carry.ee, "scissor_open", steps=10)
        tcp = s.tcp(carry.arm).p.clone()
        glide(s, {carry.arm: (tcp, tcp + up(0.08), carry.q)}, settle_steps=0)
        s.hold_until_success()
        return s.info
