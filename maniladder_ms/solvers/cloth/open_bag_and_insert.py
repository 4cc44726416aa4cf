"""Scripted solver of OpenBagAndInsert (tasks/cloth/open_bag_and_insert.py): the left Panda lifts the bag's front rim
and holds the mouth open, the right carries the cube in through the mouth and lets go, then both withdraw.

1. Rim: the left pinches a front rim particle (`RIM_PARTICLE`, left of the middle) from above, fingers opened to
   4 cm (`FINGER_GAP_CMD`) closing along a diagonal of the grid (`RIM_GRASP_TURN`), and lifts it `RIM_LIFT` up and
   `RIM_BACK` in: the mouth opens into an arch facing the robot.
2. Cube: the right picks the cube from above, fingers closing along the bag's mouth-to-bottom axis (the hand's long
   side along it, so it passes beside the left hand), lines it up `ENTRY_OUT` in front of the mouth, `ENTRY_ASIDE`
   right of the held particle, `ENTRY_HEIGHT` up, and carries it `ENTRY_DEPTH` past the mouth into the bag.
3. Let go: the right opens, backs straight out of the mouth and rises; the left lets the rim go where it holds it
   and rises.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.cloth.open_bag_and_insert import HOLDER, INSERTER, OpenBagAndInsertEnv

FINGER_GAP_CMD = 0.2  # normalised gripper command: fingers 4 cm apart, around one rim particle only
GRASP_ABOVE = 0.003  # the TCP this far above a particle's centre: the pads pinch its sides
# the left's fingers close along a diagonal of the sheet's grid, turned this far from the rim: the inner finger goes
# down into the hole between the rim's neighbour and the next row, clear of both. Closing across the rim (on the
# next row's particle) held the lifted rim on 4 of seeds 100-107, diagonally on 5 of 5 failed and held ones
# (100, 101, 103, 106, 107); turned this way the hand's long side points into the bag on the right's side, away
# from the right hand outside the mouth
RIM_GRASP_TURN = -np.pi / 4
# the left pinches the front rim's particle 4 of 10 (local y -1.5 cm: 1.25 cm left of the mouth's middle once
# turned to face the robot), closing across the rim
RIM_PARTICLE = 4
RIM_LIFT = 0.08  # the held rim particle this high above where it lay: the mouth opens into an arch
RIM_BACK = 0.03  # and this far towards the bag's bottom, away from the right hand's way in
LIFT_STEP = 0.006  # metres per control step while lifting the rim
CARRY_HEIGHT = 0.08  # the cube lifted this high from the table after the pick
ENTRY_ASIDE = 0.05  # the cube goes in this far to the right of the held particle, along the rim (2 spacings)
ENTRY_PITCH = np.deg2rad(45)  # the right's fingers point into the bag this far below the horizontal: the hand stays outside
ENTRY_OUT = 0.06  # it lines up this far in front of the mouth (the back rim's line), outside the bag
ENTRY_DEPTH = 0.055  # and is carried this far past the mouth line, into the bag
ENTRY_HEIGHT = 0.045  # the cube's centre this high while it goes in: its bottom 1.4 cm over the back panel's top
ENTRY_STEP = 0.005  # metres per control step while the cube goes in
RELEASE_STEPS = 10  # control steps an opening gripper waits
BACK_OUT = 0.08  # the right backs out of the bag this far, straight out of the mouth, after letting go
RISE = 0.08  # and rises this far


def _rim_and_axes(task: OpenBagAndInsertEnv):
    """The held rim particle's position, the back rim's middle, the bag's mouth-to-bottom axis (horizontal, unit)
    and the rim's direction (horizontal, unit, from the held particle towards the rest of the rim's -y end)."""
    points = task.bag.positions()
    named = task.bag.layout.named
    held = points[:, named["front_rim"][RIM_PARTICLE]]
    back_rim = points[:, named["back_rim"]]
    bottom = points[:, named["back_bottom"]].mean(dim=1)
    inward = bottom - back_rim.mean(dim=1)
    inward[:, 2] = 0
    inward = torch.nn.functional.normalize(inward, dim=1)
    along = back_rim[:, -1] - back_rim[:, 0]
    along[:, 2] = 0
    along = torch.nn.functional.normalize(along, dim=1)
    return held, back_rim.mean(dim=1), inward, along


@register_solver("OpenBagAndInsert", control_modes=TCP_DELTA_MODES)
def solve_open_bag_and_insert(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: OpenBagAndInsertEnv = env.unwrapped
        n, device = task.num_envs, task.device
        left_arm, left_ee = f"{HOLDER}_arm", f"{HOLDER}_gripper"
        right_arm, right_ee = f"{INSERTER}_arm", f"{INSERTER}_gripper"
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        # 1. rim
        held, mouth, inward, along = _rim_and_axes(task)
        rim_yaw = torch.atan2(along[:, 1], along[:, 0]) + RIM_GRASP_TURN
        q_left = top_down_quat(DrivenSolver.neutral_yaw(rim_yaw, np.pi), n, device)
        s.set_ee(left_ee, [FINGER_GAP_CMD], steps=0)
        s.move({left_arm: (held + APPROACH_HEIGHT * up, q_left)}, max_steps=60)
        held, mouth, inward, along = _rim_and_axes(task)
        s.move({left_arm: (held + GRASP_ABOVE * up, q_left)}, max_steps=40, pos_tol=0.003)
        s.grasp(left_ee)
        start = s.tcp(left_arm).p.clone()
        open_at = start + RIM_LIFT * up + RIM_BACK * inward
        glide(s, {left_arm: (start, open_at, q_left)}, step_length=LIFT_STEP, settle_steps=10)
        # 2. cube: picked with the fingers closing along the bag's mouth-to-bottom axis (the hand's long side along
        # it, beside the left hand), carried in front of the mouth, in, let go
        cube = task.cube.pose
        cube_yaw = 2 * torch.atan2(cube.q[:, 3], cube.q[:, 0])
        in_yaw = torch.atan2(inward[:, 1], inward[:, 0])  # closing along the rim
        yaw = in_yaw + DrivenSolver.neutral_yaw(cube_yaw - in_yaw, np.pi / 2)  # the face pair nearest that
        s.pick(right_arm, right_ee, cube.p.clone(), DrivenSolver.neutral_yaw(yaw, np.pi), lift=CARRY_HEIGHT)
        _, mouth, inward, along = _rim_and_axes(task)
        pointing = np.cos(ENTRY_PITCH) * inward - np.sin(ENTRY_PITCH) * up
        q_right = tcp_quat(pointing, along)
        held_p = task.bag.positions()[:, task.bag.layout.named["front_rim"][RIM_PARTICLE]]
        aside = ((held_p - mouth) * along).sum(dim=1, keepdim=True) + ENTRY_ASIDE
        line = mouth + aside * along
        line[:, 2] = ENTRY_HEIGHT
        outside, inside = line - ENTRY_OUT * inward, line + ENTRY_DEPTH * inward
        above = outside.clone()
        above[:, 2] = CARRY_HEIGHT
        s.move({right_arm: (above, q_right)}, max_steps=80, pos_tol=0.01, rot_tol=0.05)
        s.move({right_arm: (outside, q_right)}, max_steps=40, pos_tol=0.005)
        glide(s, {right_arm: (outside, inside, q_right)}, step_length=ENTRY_STEP, settle_steps=10)
        # 3. let go: the right opens and backs out; the left lowers the rim and lets go
        s.release(right_ee, steps=RELEASE_STEPS)
        out = s.tcp(right_arm).p - BACK_OUT * inward
        s.move({right_arm: (out, q_right)}, max_steps=40, pos_tol=0.01)
        s.move({right_arm: (out + RISE * up, q_right)}, max_steps=30, pos_tol=0.01)
        s.release(left_ee, steps=RELEASE_STEPS)
        s.move({left_arm: (s.tcp(left_arm).p + RISE * up, q_left)}, max_steps=30, pos_tol=0.01)
        s.hold_until_success()
        return s.info
