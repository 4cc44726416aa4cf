"""The InsertPeg family's shared solver phases (DrivenSolver, pd_ee_delta_pose): the two-arm rows' grasps and lift
(`lift_block_and_peg`), and a held peg carried over the hole, lined up with its axis (closed loop on the measured
peg and block), inserted, let go (`insert_held_peg`)."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import matrix_yaw, wrap_angle, yaw_of
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rigid.insert_peg.base import HeldBlockInsertTask, InsertPegTask

GRASP_BELOW_TOP = 0.025  # the TCP this far below the peg's top face: the finger pads hold its upper end
HOVER = 0.015  # the peg's lower end this high over the rim while it is lined up with the hole
LINE_UP_TOL = 0.0005  # m: the lower end's lateral offset from the hole's axis before going down
DESCENT_STEP = 0.002  # m per control step the target goes down
FLOOR_GAP = 0.003  # the insertion stops with the lower end this high over the hole's floor
CARRY_ABOVE = 0.05  # the peg is carried to this far above its HOVER pose before the closed-loop line-up
HOVER_TOL = 0.002  # m: the line-up is done once the lower end is no lower than this below HOVER too
FLOOR_TOL = 0.001  # m: the descent is done once the lower end is within this of FLOOR_GAP
BACK_OFF = 0.06  # m the open gripper rises after letting go


# the two-arm rows (InsertPegBimanual, InsertTableLeg): `lift_block_and_peg`
BLOCK_LIFT = 0.1  # metres the left gripper raises the block
# of the two top-down hand yaws of a grasp, each arm takes the one nearest these: the left's wrist camera (on
# the hand's +x side) points away from the hole, and joint 7 stays clear of its limits all the way (the
# right's other choice ran it into +2.9 rad as it carried the peg to the left). The right's camera then faces
# the left hand: the 12 cm handle keeps the hands ~12.6 cm apart (at 8 cm they jammed in 6 of 6 seeds)
RIGHT_YAW = np.pi / 2
LEFT_YAW = np.pi / 2
PEG_LIFT = 0.2  # ... and the right one the peg: its lower end clears the raised block
RAISE_STEP = 0.015  # metres a control step both arms rise together


def lift_block_and_peg(s, task: HeldBlockInsertTask, left_yaw: float = LEFT_YAW, right_yaw: float = RIGHT_YAW,
                       block_lift: float = BLOCK_LIFT, peg_lift: float = PEG_LIFT, raise_step: float = RAISE_STEP):
    """The two-arm rows' grasps and lift: both arms reach at once, the left to the handle (top-down, fingers
    across it; of its two hand yaws the one nearest `left_yaw`), the right to the peg's upper end (top-down,
    fingers across the two faces that will face the handle's sides; the hand yaw nearest `right_yaw`); both
    close, then rise together, `raise_step` a control step: the block by `block_lift`, the peg by `peg_lift`."""
    n, device = task.num_envs, task.device
    block_yaw = yaw_of(task.block.pose.q)
    left_q = top_down_quat(DrivenSolver.neutral_yaw(block_yaw - left_yaw, np.pi) + left_yaw, n, device)
    # the right fingers close along the block's y (across the handle): its hand lies clear of the left's
    peg_yaw = yaw_of(task.peg.pose.q)
    face = block_yaw + torch.remainder(peg_yaw - block_yaw + np.pi / 4, np.pi / 2) - np.pi / 4
    right_q = top_down_quat(DrivenSolver.neutral_yaw(face - right_yaw, np.pi) + right_yaw, n, device)
    peg_grasp = task.peg.pose.p.clone()
    peg_grasp[:, 2] += task.peg_length / 2 - GRASP_BELOW_TOP
    above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
    grasps = [Grasp("left_arm", "left_gripper", task.handle_point(), left_q, above),
              Grasp("right_arm", "right_gripper", peg_grasp, right_q, above)]
    reach(s, grasps)
    grasp_together(s, ["left_gripper", "right_gripper"])
    up = torch.tensor([0.0, 0.0, 1.0], device=device)
    glide(s, {"left_arm": (grasps[0].p, grasps[0].p + block_lift * up, left_q),
              "right_arm": (grasps[1].p, grasps[1].p + peg_lift * up, right_q)}, step_length=raise_step,
          settle_steps=5)


def peg_in_hand(task: InsertPegTask, ee_side: str | None) -> Pose:
    """The peg's pose in the TCP frame, measured now."""
    return task.ee.tcp(ee_side).inv() * task.peg.pose


def peg_goal_tcp(task: InsertPegTask, peg_in_tcp: Pose, tip_height: float, prefer_yaw: float | None = None):
    """(p, q) of the TCP that puts the held peg (`peg_in_tcp`: where it sits in the hand) on the hole's axis,
    its lower end `tip_height` above the rim (along the axis), its faces along the hole's walls (of the four
    such yaws the nearest to the peg's now; given `prefer_yaw`, the one that leaves the TCP's yaw nearest it,
    so a peg held about 45 degrees off the hole's walls turns the same way whichever way the grasp nudged it).
    The block's pose is read now: the goal follows a moving block."""
    peg_in_block = (task.block.pose.inv() * task.peg.pose).to_transformation_matrix()
    turns = torch.round(matrix_yaw(peg_in_block) / (np.pi / 2)) * (np.pi / 2)
    goal = _peg_goal(task, peg_in_tcp, tip_height, turns)
    if prefer_yaw is not None:  # a quarter turn more of the peg about the hole's axis turns the TCP's yaw as much
        off = wrap_angle(prefer_yaw - matrix_yaw(goal.to_transformation_matrix()))
        turns = turns + torch.round(off / (np.pi / 2)) * (np.pi / 2)
        goal = _peg_goal(task, peg_in_tcp, tip_height, turns)
    return goal.p, goal.q


def _peg_goal(task: InsertPegTask, peg_in_tcp: Pose, tip_height: float, turns: torch.Tensor) -> Pose:
    """The TCP pose of `peg_goal_tcp` for the peg turned `turns` (rad) about the hole's axis in the block's frame."""
    n = task.num_envs
    local_p = torch.zeros(n, 3, device=task.device)
    local_p[:, 2] = task.hole.rim_height + tip_height + task.peg_length / 2
    local_q = torch.stack([torch.cos(turns / 2), torch.zeros_like(turns), torch.zeros_like(turns),
                           torch.sin(turns / 2)], 1)
    return task.block.pose * Pose.create_from_pq(local_p, local_q) * peg_in_tcp.inv()


def insert_held_peg(s, task: InsertPegTask, arm: str, ee_part: str, ee_side: str | None,
                    line_up_steps: int = 40, max_descent_steps: int = 60, prefer_yaw: float | None = None):
    """Carry the held peg over the hole, line its lower end up with the hole's axis (closed loop on the
    measured peg and block), go down the hole to `FLOOR_GAP` above its floor, let go and back off upwards.
    Where the peg sits in the hand is measured while it hangs free and then kept: once the hole's walls
    touch it, it turns in the fingers, and a goal that followed it would turn the hand after it.
    `prefer_yaw`: see `peg_goal_tcp`."""
    grip = peg_in_hand(task, ee_side)
    s.move({arm: peg_goal_tcp(task, grip, HOVER + CARRY_ABOVE, prefer_yaw)}, max_steps=60, pos_tol=0.005, rot_tol=0.05)
    grip = peg_in_hand(task, ee_side)
    for _ in range(line_up_steps):
        s.step({arm: peg_goal_tcp(task, grip, HOVER, prefer_yaw)})
        info = task.insertion_state()
        if bool((info["offset"] < LINE_UP_TOL).all() & (info["depth"] > -HOVER - HOVER_TOL).all()):
            break
    height = HOVER
    bottom = -(task.hole_depth - FLOOR_GAP)
    for _ in range(max_descent_steps):
        height = max(height - DESCENT_STEP, bottom)
        s.step({arm: peg_goal_tcp(task, grip, height, prefer_yaw)})
        if bool((task.insertion_state()["depth"] >= task.hole_depth - FLOOR_GAP - FLOOR_TOL).all()):
            break
    s.release(ee_part, steps=8)
    tcp = s.tcp(arm)
    s.move({arm: (s.above(tcp.p, BACK_OFF), tcp.q)}, max_steps=20, pos_tol=0.01)
