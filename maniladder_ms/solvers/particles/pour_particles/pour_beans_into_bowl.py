"""Scripted solver of PourBeansIntoBowl (tasks/particles/pour_particles/pour_beans_into_bowl.py): a level side
grasp of the cup and a wrist roll over the bowl.

1. grasp the cup level from its outer side, pointing in 30 degrees forward of the y axis (the IK has room there),
   and lift it;
2. carry it to POUR_BACK behind the bowl's centre;
3. roll the wrist so the cup's mouth turns forward over the bowl, and hold until the beans are in.
"""

from __future__ import annotations

import numpy as np
import sapien

from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.particles.pour_particles.pour_beans_into_bowl import PourBeansIntoBowlEnv

GRASP_HEIGHT = 0.045  # TCP height above the cup's bottom
POUR_HEIGHT = 0.13  # TCP height while pouring
POUR_BACK = 0.04  # the TCP stops this far behind the bowl's centre
POUR_ROLL = 2.5  # rad (143 degrees)
POUR_ROLL_STEPS = 20


# pd_joint_pos only: the joint-delta and TCP-delta modes lag the fast wrist roll and missed (0/4 seeds in
# pd_joint_delta_pos; pd_ee_delta_pose not one success in 12 minutes of demo generation), not tuned yet
@register_solver("PourBeansIntoBowl", control_modes=("pd_joint_pos",))
def solve_pour_beans_into_bowl(env, seed: int) -> dict:
    """Grasp the cup level from its outer side, lift, carry it behind the bowl, roll the wrist forward."""
    with PandaSolver.episode(env, seed) as robot:
        task: PourBeansIntoBowlEnv = env.unwrapped
        cup_p = task.cup.pose.p[0].cpu().numpy()
        bowl_p = task.bowl.pose.p[0].cpu().numpy()
        side = 1.0 if cup_p[1] >= 0 else -1.0
        yaw = -side * np.pi / 3
        # on the -y side the mirrored grasp would leave the last joint no room to roll: turn it half a turn
        grasp = robot.level_pose([cup_p[0], cup_p[1], GRASP_HEIGHT], yaw, closing_sign=side)
        robot.pick(grasp, approach_from=-0.1 * np.array([np.cos(yaw), np.sin(yaw), 0.0]))
        robot.move(sapien.Pose([bowl_p[0] - POUR_BACK, bowl_p[1], POUR_HEIGHT], grasp.q))
        # a positive roll about the pointing axis turns the cup's mouth towards (pointing x up)
        forward = np.cross([np.cos(yaw), np.sin(yaw), 0.0], [0.0, 0.0, 1.0])[0]
        robot.roll_wrist(POUR_ROLL * np.sign(forward), POUR_ROLL_STEPS)
        robot.hold_until_success()
        return robot.info
