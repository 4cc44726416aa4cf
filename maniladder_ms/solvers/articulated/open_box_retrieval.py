"""Scripted solver of OpenBoxRetrieval (tasks/articulated/open_box_retrieval.py): the gripper lifts the lid by its
lip until it falls open, then picks the cube out of the box.

1. Open the lid (`solvers.lids.open_lid`): hook the fingers under the lip and swing it past vertical.
2. Pick the cube top-down at its yaw (the yaw within the cube's quarter-turn symmetry nearest the gripper's
   neutral one) and lift it `LIFT` clear.
3. Hold until success.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.lids import open_lid
from maniladder_ms.tasks.articulated.open_box_retrieval import OpenBoxRetrievalEnv

CUBE_SYMMETRY = np.pi / 2  # rad, the cube looks the same after this much yaw
LIFT = 0.15  # m the picked cube is lifted


@register_solver("OpenBoxRetrieval", control_modes=TCP_DELTA_MODES)
def solve_open_box_retrieval(env, seed: int) -> dict:
    """Lift the lid by its lip past vertical (it falls open), then pick the cube out of the box."""
    with DrivenSolver.episode(env, seed) as robot:
        task: OpenBoxRetrievalEnv = env.unwrapped
        open_lid(robot, "arm", "gripper", task.box, task.box_shape)
        cube_yaw = robot.neutral_yaw(yaw_of(task.cube.pose.q), CUBE_SYMMETRY)
        robot.pick("arm", "gripper", task.cube.pose.p, cube_yaw, lift=LIFT)
        robot.hold_until_success()
        return robot.info
