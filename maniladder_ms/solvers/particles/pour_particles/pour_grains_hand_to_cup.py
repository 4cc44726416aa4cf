"""Scripted solver of PourGrainsHandToCup (tasks/particles/pour_particles/pour_grains_hand_to_cup.py): both LEAP
hands take side grasps (`solvers.side_grasps`), the holder on the cup, the pourer on the glass, which it lifts,
carries beside the cup and rolls over it.

1. from the ready pose both hands go above their line-up points, take their approach synergies and come down to
   them, then move in;
2. both close: the holder on the cup, the pourer on the glass;
3. the pourer lifts the glass and carries it upright to CARRY_BESIDE from the cup, on the side opposite the pour;
4. it rolls the glass about its palm normal, the mouth steered over the cup and its bottom edge clear of the
   cup's rim (`pouring.steer_roll`), and holds until the grains are in.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import close_hands, glide
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.pouring import steer_roll
from maniladder_ms.solvers.side_grasps import LEFT_THUMB_LOW_GRASP, LINE_UP_ABOVE, SIDE_PRESHAPE_STEPS, lined_up_side_grasp
from maniladder_ms.tasks.particles.pour_particles.pour_grains_hand_to_cup import HOLDER, POURER, PourGrainsHandToCupEnv
from maniladder_ms.solvers.postures import LEAP_SYNERGIES

# Side grasps: the palm normal's yaw, its tilt below the horizontal, which way the finger row runs (the TCP's y
# along +-z: the pourer's thumb low, the holder's high), the TCP's height above the container's floor, and its
# shifts along the TCP's x (towards where the fingers start to curl) and along the palm normal (past the axis).
SIDE_GRASP = {
    POURER: LEFT_THUMB_LOW_GRASP,  # the glass
    # the cup, palm tilted 0.3 rad down: "power"'s fingers and the thumb swung in 1 rad, straight, pressing the
    # cup's near side below the rim (seeds 106/107/109/110: fingers only held by one fingertip and a flickering
    # palm contact, the cup counted held on 8 of 15 seeds; a thumb swung 0.6 or curled at its outer joints reached
    # over the rim and 18-55 % of the grains got in; this thumb: 3/4, thumb 8-38 N, three fingertips 6-14 N).
    # The hand comes in open: "preshape"'s swung thumb met the cup first and tilted it 17-24 deg. Its row's
    # lowest finger clears the table at a TCP height of 7.5 cm
    HOLDER: dict(yaw=np.pi / 2, pitch=0.3, up=-1.0, height=0.075, shift=0.02, inwards=0.035,
                 approach="open", close=LEAP_SYNERGIES["side_power_thumb_straight"]),
}
LIFT = 0.1
CARRY_STEP = 0.01  # m per control step
CARRY_BESIDE = 0.08  # the upright glass' axis this far from the cup's, against the pour direction
# the glass' bottom above the table while carried, and the mouth's height at the end of the roll: with 0.14 /
# 0.16 the glass and the pourer's fingers hit the holder's hand (held on 1 of 5 seeds), with 0.18 / 0.19 4 of 5
CARRY_BOTTOM, MOUTH_HEIGHT = 0.18, 0.19
# rad about the pourer's palm normal (-y): this sign tips the mouth towards the robot (-x), turning the left
# Panda's joint 7 from -1.5 to ~1.0 rad (the other sign would need -3.9, past its limit)
POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS = 2.4, 70, 60
CLEAR = 0.02  # the glass' lower bottom edge clears the cup's rim by this during the roll


@register_solver("PourGrainsHandToCup", control_modes=TCP_DELTA_MODES)
def solve_pour_grains_hand_to_cup(env, seed: int) -> dict:
    """Both hands line up beside their containers from the ready pose and move in; the holder closes on the
    cup, the pourer on the glass, lifts it, carries it upright beside the cup and rolls it over the cup."""
    with DrivenSolver.episode(env, seed) as s:
        task: PourGrainsHandToCupEnv = env.unwrapped
        grasps, normals = [], {}
        for side, vessel in ((HOLDER, task.bowl), (POURER, task.cup)):
            grasp, normals[side] = lined_up_side_grasp(f"{side}_arm", f"{side}_hand", vessel.pose.p, SIDE_GRASP[side])
            grasps.append(grasp)
        s.move({g.arm: (s.above(g.lined_up[0], LINE_UP_ABOVE), g.q) for g in grasps}, max_steps=60, pos_tol=0.01)
        for g, side in zip(grasps, (HOLDER, POURER)):
            s.set_ee(g.ee, SIDE_GRASP[side]["approach"], steps=0)
        for _ in range(SIDE_PRESHAPE_STEPS):
            s.step()
        s.move({g.arm: g.lined_up for g in grasps}, max_steps=60)
        s.move({g.arm: (g.p, g.q) for g in grasps}, max_steps=40, pos_tol=0.003)
        close_hands(s, {g.ee: SIDE_GRASP[side]["close"] for g, side in zip(grasps, (HOLDER, POURER))})
        glass = grasps[1]
        s.move({glass.arm: (s.above(glass.p, LIFT), glass.q)}, max_steps=30)
        # the roll tips the mouth along palm normal x up: carry the glass to the cup's other side
        direction = torch.linalg.cross(normals[POURER], torch.tensor([[0.0, 0.0, 1.0]], device=task.device).expand_as(glass.p))
        held = s.tcp(glass.arm).p - task.cup.pose.p  # the TCP relative to the glass' bottom, as held
        carry = task.bowl.pose.p - CARRY_BESIDE * direction + held
        carry[:, 2] = CARRY_BOTTOM + held[:, 2]
        glide(s, {glass.arm: (s.tcp(glass.arm).p, carry, glass.q)}, step_length=CARRY_STEP)
        # roll the glass about the palm normal, its mouth steered to MOUTH_HEIGHT over the cup, its bottom edge
        # clearing the cup's rim
        end = task.bowl.pose.p.clone()
        end[:, 2] = MOUTH_HEIGHT
        rim_z = torch.full((task.num_envs,), task.bowl_shape.inner[-1][0], device=task.device)
        steer_roll(s, task, glass.arm, normals[POURER], glass.q, end, rim_z, POUR_ROLL, POUR_ROLL_STEPS,
                   POUR_HOLD_STEPS, CLEAR)
        s.hold_until_success(max_steps=40)
        return s.info
