"""Motion helpers for a single Panda with a parallel gripper (mplib motion planning).

Wraps ManiSkill's `PandaArmMotionPlanningSolver` (mplib 0.1.1) with top-down grasp poses and
pick/place phases the task solvers compose. The planner commands joint-position targets; through
`JointTargetAdapter` the env may run in pd_joint_pos, pd_joint_delta_pos or pd_ee_delta_pose.
"""

from __future__ import annotations

import numpy as np
import sapien

from mani_skill.examples.motionplanning.panda.motionplanner import PandaArmMotionPlanningSolver

from . import PlanningFailed
from .adapters import JointTargetAdapter
from .base import SolverBase

# joint speed/acceleration limits for planned paths (rad/s, rad/s^2); the Panda's own are ~2.2 rad/s
JOINT_VEL_LIMIT = 2.0
JOINT_ACC_LIMIT = 4.0
# holding still at the end of a path: always this many steps at grasp and release poses, where the PD
# tracking lag matters most, and on any move until the arm is this close (rad) to its goal
PRECISE_SETTLE_STEPS = 2
SETTLE_TOLERANCE = 0.02
MAX_SETTLE_STEPS = 10
PLANNED_APPROACH_HEIGHT = 0.08  # metres above a grasp or release pose where the planned straight descent starts (the
# closed-loop solvers' driven.APPROACH_HEIGHT is 0.1: another name for another number)


class PandaSolver(SolverBase):
    """Pick/place primitives for the single-arm Panda; all poses are TCP poses in the world frame."""

    def __init__(self, env):
        self.env = env
        base = env.unwrapped
        self.planner = PandaArmMotionPlanningSolver(
            JointTargetAdapter(env),
            debug=False,
            vis=False,
            base_pose=base.agent.robot.pose,
            visualize_target_grasp_pose=False,
            print_env_info=False,
            joint_vel_limits=JOINT_VEL_LIMIT,
            joint_acc_limits=JOINT_ACC_LIMIT,
        )
        self.planner.control_mode = "pd_joint_pos"  # what the adapter accepts, whatever the env's mode

    def close(self):
        self.planner.close()

    def top_down_pose(self, center, yaw: float) -> sapien.Pose:
        """TCP pointing straight down at `center`, fingers closing along the horizontal direction `yaw`."""
        closing = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        return self.env.unwrapped.agent.build_grasp_pose(np.array([0, 0, -1.0]), closing, np.asarray(center, float))

    def level_pose(self, center, yaw: float, closing_sign: float = 1.0) -> sapien.Pose:
        """TCP pointing horizontally along the direction `yaw` at `center`, fingers closing horizontally
        (across the pointing direction; `closing_sign` -1 turns the hand half a turn about it: the same
        grasp with the last joint pi away, to leave it room for a later `roll_wrist`)."""
        approaching = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        closing = closing_sign * np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        return self.env.unwrapped.agent.build_grasp_pose(approaching, closing, np.asarray(center, float))

    def roll_wrist(self, angle: float, steps: int):
        """Turn the last arm joint, whose axis is the TCP's pointing axis, by `angle` rad at an even pace
        over `steps` control steps, the other joints held: a pour from a level grasp (the Panda cannot
        pitch its hand far forward, joint 6 reaches its limit, but rolls it freely)."""
        arm = self.env.unwrapped.agent.robot
        start = arm.get_qpos()[0, :7].cpu().numpy()
        for k in range(1, steps + 1):
            goal = start.copy()
            goal[6] += angle * k / steps
            self.last = self.planner.follow_path({"position": goal[None]})

    def straight_line_yaw(self, center, yaws) -> float:
        """The first of the equivalent `yaws` whose top-down pose at `center` is reachable by a straight
        (screw) path from here: the RRT fallback may sweep the arm through objects on the table."""
        for yaw in yaws:
            if self.planner.move_to_pose_with_screw(self.top_down_pose(center, yaw), dry_run=True) != -1:
                return yaw
        return yaws[0]

    def current_yaw(self) -> float:
        m = self.env.unwrapped.agent.tcp.pose.to_transformation_matrix()[0, :3, :3].cpu().numpy()
        return float(np.arctan2(m[1, 1], m[0, 1]))

    def closest_grasp_yaw(self, yaw: float, period: float = np.pi) -> float:
        """Of the yaws equivalent to `yaw` modulo `period` (a symmetric grasp), the one nearest the current TCP."""
        cur = self.current_yaw()
        return cur + (yaw - cur + period / 2) % period - period / 2

    def move(self, pose: sapien.Pose, settle_steps: int = 0):
        """Plan a path to `pose` and follow it, then hold the last waypoint for at least `settle_steps`
        and until the arm is within SETTLE_TOLERANCE of it (at most MAX_SETTLE_STEPS): the PD lag,
        larger in the delta control modes, must not leave a grasp or a release short of its pose."""
        plan = self.planner.move_to_pose_with_screw(pose, dry_run=True)
        if plan == -1:
            plan = self.planner.move_to_pose_with_RRTConnect(pose, dry_run=True)
        if plan == -1:
            raise PlanningFailed(f"no path to {pose}")
        self.last = self.planner.follow_path(plan)
        goal = plan["position"][-1]
        arm = self.env.unwrapped.agent.robot
        for step in range(MAX_SETTLE_STEPS):
            error = np.abs(arm.get_qpos()[0, : len(goal)].cpu().numpy() - goal).max()
            if step >= settle_steps and error < SETTLE_TOLERANCE:
                break
            self.last = self.planner.follow_path({"position": goal[None]})

    def grip(self, closed: bool, part: str = "gripper", steps: int = 6):
        """Close or open the gripper over `steps` steps (the signature of `Driver.grip`: the Panda has one part)."""
        if part != "gripper":
            raise ValueError(f"the single Panda has one end effector, 'gripper', not {part!r}")
        self.last = self.planner.close_gripper(t=steps) if closed else self.planner.open_gripper(t=steps)

    def hold_still(self):
        self.grip(closed=self.planner.gripper_state == self.planner.CLOSED, steps=1)

    def pick(self, grasp: sapien.Pose, approach_height: float = PLANNED_APPROACH_HEIGHT, lift_height: float = 0.1,
             approach_from=None):
        """Grasp at `grasp` from `approach_from` (a world offset from it; default: `approach_height` above),
        coming in along a straight line, close, lift by `lift_height`."""
        offset = [0, 0, approach_height] if approach_from is None else list(approach_from)
        self.move(sapien.Pose(offset) * grasp)
        self.move(grasp, settle_steps=PRECISE_SETTLE_STEPS)
        self.grip(closed=True)
        self.move(sapien.Pose([0, 0, lift_height]) * grasp)

    def place(self, release: sapien.Pose, approach_height: float = PLANNED_APPROACH_HEIGHT, retreat_height: float = 0.06):
        self.move(sapien.Pose([0, 0, approach_height]) * release)
        self.move(release, settle_steps=PRECISE_SETTLE_STEPS)
        self.grip(closed=False)
        self.move(sapien.Pose([0, 0, retreat_height]) * release)
