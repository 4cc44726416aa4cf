"""Scripted solver of SortCubesByColor (tasks/rigid/sort_cubes_by_color.py): each colour cube, nearest its bin
first, is picked top-down and dropped into the bin of its colour, planned with mplib; the distractor cubes are
left where they lie.

Per colour cube:
1. Pick it top-down (grasp yaw the nearest of its four faces) and lift it to `CARRY_HEIGHT`.
2. Carry it over the centre of its bin and let it go with its underside `RELEASE_ABOVE_RIM` above the bin's wall
   tops (open fingers between the walls would push the bin), then retreat up.
Then hold until success.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import actor_yaw
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.rigid.sort_cubes_by_color import SortCubesByColorEnv

CARRY_HEIGHT = 0.1  # m of the TCP above the table while carrying: the held cube's underside clears the 3 cm walls
RELEASE_ABOVE_RIM = 0.01  # m between the held cube's underside and the bin's wall tops when the fingers open


@register_solver("SortCubesByColor")
def solve_sort_cubes_by_color(env, seed: int) -> dict:
    """Move every colour cube into its own bin, the one nearest its bin first."""
    with PandaSolver.episode(env, seed) as robot:
        task: SortCubesByColorEnv = env.unwrapped
        cube_p = [c.pose.p[0].cpu().numpy() for c in task.cubes]
        bin_p = [b.pose.p[0].cpu().numpy() for b in task.bins[: task.num_sorted]]
        order = sorted(range(task.num_sorted), key=lambda i: np.linalg.norm(cube_p[i][:2] - bin_p[i][:2]))
        for i in order:
            cube = task.cubes[i]
            p = cube.pose.p[0].cpu().numpy()
            lift = CARRY_HEIGHT - p[2]
            robot.pick(robot.top_down_pose(p, robot.closest_grasp_yaw(actor_yaw(cube), np.pi / 2)),
                       approach_height=lift, lift_height=lift)
            q = task.bins[i].pose.p[0].cpu().numpy()
            release_z = task.bin_wall_height + RELEASE_ABOVE_RIM + task.half_size
            robot.place(robot.top_down_pose([q[0], q[1], release_z], robot.current_yaw()),
                        approach_height=CARRY_HEIGHT - release_z, retreat_height=CARRY_HEIGHT - release_z)
        robot.hold_until_success()
        return robot.info
