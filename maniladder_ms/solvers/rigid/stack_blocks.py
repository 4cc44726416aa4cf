"""Scripted solver of Stack6Blocks (tasks/rigid/stack_blocks.py): the block nearest `STACK_SITE` stays as the base
and every other block, nearest first, is picked top-down and placed on the current top, planned with mplib.

Per block, nearest to the base first:
1. Pick it top-down (grasp yaw the nearest of its four faces), approaching and lifting to a carry height that
   clears the tower's top by `CARRY_CLEARANCE`.
2. Place it on the block actually on top (so placement errors do not add up), released `RELEASE_GAP` above its
   resting height, and retreat above the new top.
Then hold until the tower comes to rest.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import actor_yaw
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.rigid.stack_blocks import StackBlocksEnv

STACK_SITE = (-0.05, 0.0)  # the solver builds the tower on the block nearest this point
CARRY_CLEARANCE = 0.05  # m between the carried block's bottom and the tower's top
RELEASE_GAP = 0.004  # m above its resting height where a placed block is let go


@register_solver("Stack6Blocks")
def solve_stack_blocks(env, seed: int) -> dict:
    """Keep the block nearest the workspace centre as the base; put every other block on the current top."""
    with PandaSolver.episode(env, seed) as robot:
        task: StackBlocksEnv = env.unwrapped
        pos = task._block_positions()[0].cpu().numpy()
        base = int(np.argmin(np.linalg.norm(pos[:, :2] - np.array(STACK_SITE), axis=1)))
        others = sorted((i for i in range(task.num_blocks) if i != base), key=lambda i: np.linalg.norm(pos[i, :2] - pos[base, :2]))
        size = 2 * task.half_size
        top = task.blocks[base]
        for level, i in enumerate(others, start=1):
            block = task.blocks[i]
            p = block.pose.p[0].cpu().numpy()
            # travel between the tower and the blocks at a height that clears the tower's top
            carry_z = task.half_size + size * level + CARRY_CLEARANCE
            robot.pick(robot.top_down_pose(p, robot.closest_grasp_yaw(actor_yaw(block), np.pi / 2)),
                       approach_height=carry_z - p[2], lift_height=carry_z - p[2])
            # aim at the block actually on top, so small placement errors do not add up along the tower
            top_p = top.pose.p[0].cpu().numpy()
            release_z = top_p[2] + size + RELEASE_GAP
            robot.place(robot.top_down_pose([top_p[0], top_p[1], release_z], robot.closest_grasp_yaw(actor_yaw(top), np.pi / 2)),
                        approach_height=carry_z - release_z, retreat_height=carry_z + size - release_z)
            top = block
        robot.hold_until_success()  # let the tower come to rest
        return robot.info
