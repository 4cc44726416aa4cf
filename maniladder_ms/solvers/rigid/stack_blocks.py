"""Scripted solver of Stack6Blocks (tasks/rigid/stack_blocks.py): the block nearest `STACK_SITE` stays as the base
and every other block, nearest first, is picked top-down and placed on the current top, planned with mplib.

Per block, nearest to the base first:
1. Pick it top-down across the pair of its faces that keeps the tower out of the hand's footprint (the Panda hand
   is 20 cm long along its fingers' closing axis: on seeds 103 and 106 a hand closing towards the tower 10-12 cm
   away knocked its second block off), approaching and lifting to a carry height that clears the tower's top by
   `CARRY_CLEARANCE`.
2. Place it on the block actually on top (so placement errors do not add up), released `RELEASE_GAP` above its
   resting height, and retreat above the new top.
Then hold until the tower comes to rest. Every grasp and release yaw turns the hand the least from its current yaw
within a quarter turn of its rest yaw: unbounded, the least turn each time let the wrist drift to its joint limit by
the fifth block on seed 103, where the planner's detour knocked the tower over.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import actor_yaw
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.rigid.stack_blocks import StackBlocksEnv

# the solver builds the tower on the block nearest this point: the middle of the start grid's far row (x 0.01 m).
# A tower in the near row stands under the forearm reaching for the far row: with the base nearest (-0.05, 0),
# the grid's centre, the fifth block's reach knocked five-block towers over on seeds 108 and 134
STACK_SITE = (0.01, 0.0)
CARRY_CLEARANCE = 0.05  # m between the carried block's bottom and the tower's top
RELEASE_GAP = 0.004  # m above its resting height where a placed block is let go
# the Panda hand's half extent (m) about the TCP, along the fingers' closing axis and across it (its collision
# mesh); its underside is 3.7 cm above the TCP, below the top of a tower of two blocks grasped at mid-height
HAND_HALF_LENGTH = 0.104
HAND_HALF_WIDTH = 0.032
HAND_MARGIN = 0.01  # m kept between the hand's footprint and the tower


def wrist_yaws(yaw: float, rest_yaw: float, period: float) -> list[float]:
    """The yaws equivalent to `yaw` modulo `period` within a quarter turn of `rest_yaw` (two for a cube's
    faces, period pi / 2): the last joint then stays within about 1.6 rad of its rest 0.8 rad, inside its
    +-2.9 rad limits."""
    low = rest_yaw - np.pi / 2
    first = low + (yaw - low) % period
    return [first + k * period for k in range(int(round(np.pi / period)))]


def turn(yaw: float, current_yaw: float) -> float:
    """How far (rad) the hand turns from `current_yaw` to `yaw`."""
    return abs((yaw - current_yaw + np.pi) % (2 * np.pi) - np.pi)


def in_hand_footprint(yaw: float, to_tower: np.ndarray, half_size: float) -> bool:
    """Whether the tower (`to_tower`: block to tower, m) stands under a top-down hand closing along `yaw`."""
    reach = half_size * np.sqrt(2) + HAND_MARGIN  # the tower's half diagonal, whatever its yaw
    along = abs(np.cos(yaw) * to_tower[0] + np.sin(yaw) * to_tower[1])
    across = abs(-np.sin(yaw) * to_tower[0] + np.cos(yaw) * to_tower[1])
    return along < HAND_HALF_LENGTH + reach and across < HAND_HALF_WIDTH + reach


def clear_grasp_yaw(block_yaw: float, rest_yaw: float, current_yaw: float, to_tower: np.ndarray,
                    half_size: float) -> float:
    """The top-down grasp yaw (the fingers' closing direction) across a pair of the block's faces, within a quarter
    turn of the rest yaw: of the pairs that keep the tower out of the hand's footprint, the least turn from now."""
    yaws = wrist_yaws(block_yaw, rest_yaw, np.pi / 2)
    clear = [yaw for yaw in yaws if not in_hand_footprint(yaw, to_tower, half_size)]
    return min(clear or yaws, key=lambda yaw: turn(yaw, current_yaw))


@register_solver("Stack6Blocks")
def solve_stack_blocks(env, seed: int) -> dict:
    """Keep the block nearest the workspace centre as the base; put every other block on the current top."""
    with PandaSolver.episode(env, seed) as robot:
        task: StackBlocksEnv = env.unwrapped
        rest_yaw = robot.current_yaw()
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
            robot.pick(robot.top_down_pose(p, clear_grasp_yaw(actor_yaw(block), rest_yaw, robot.current_yaw(),
                                                           top.pose.p[0].cpu().numpy() - p, task.half_size)),
                       approach_height=carry_z - p[2], lift_height=carry_z - p[2])
            # aim at the block actually on top, so small placement errors do not add up along the tower
            top_p = top.pose.p[0].cpu().numpy()
            release_yaw = min(wrist_yaws(actor_yaw(top), rest_yaw, np.pi / 2),
                              key=lambda yaw: turn(yaw, robot.current_yaw()))
            release_z = top_p[2] + size + RELEASE_GAP
            robot.place(robot.top_down_pose([top_p[0], top_p[1], release_z], release_yaw),
                        approach_height=carry_z - release_z, retreat_height=carry_z + size - release_z)
            top = block
        robot.hold_until_success()  # let the tower come to rest
        return robot.info
