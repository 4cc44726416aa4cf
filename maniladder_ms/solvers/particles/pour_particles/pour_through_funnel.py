"""Scripted solver of PourThroughFunnel (tasks/particles/pour_particles/pour_through_funnel.py): the left gripper
takes the funnel by its tab (pointing to the left) and sets its neck into the bottle's neck; the right takes the cup in
a level side grasp and, from in front of the funnel, rolls it over the funnel's mouth.

1. both arms line up together, the left top-down above the funnel's tab (the hand turned LEFT_YAW_TURN so that its
   wrist stands out beyond the tab, not over the funnel), the right level beside the cup; the tab is re-aimed once
   the funnel has settled in its stand; both move in and close together;
2. the left draws the funnel slowly straight up out of its stand (PULL_OUT at PULL_STEP a step); if the funnel
   is not held then (the pinch slipped off the tab), it opens, rises, aims at the tab anew and pinches again
   (GRASP_RETRIES; still not held, the episode ends there, failed); both lift: the left by FUNNEL_LIFT (the neck
   clear of the stand and of the bottle), the right by CUP_LIFT;
3. the left carries the funnel's outlet NECK_ABOVE above the bottle's mouth, then lowers it NECK_DEPTH into the
   bottle's neck (both servoed on the funnel's measured outlet);
4. the right carries the cup SOURCE_BACK in front of and SOURCE_ABOVE above the funnel and rolls it (ROLL_SIGN)
   about its pointing axis, the mouth steered to POUR_OFFSET off the funnel's axis away from its tab (`pouring.
   steer_roll`), and holds until the water is in. MOUTH_ABOVE is high because the rolling hand's edge dips ~10 cm
   below the TCP half-way through the roll; POUR_OFFSET keeps the rolling cup off the left hand and wrist above the
   tab (aimed at the axis, the cup struck the left arm's link 7 and drove the funnel into the bottle, seed 106).
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.geometry import tcp_quat, yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.pouring import steer_roll
from maniladder_ms.tasks.particles.pour_particles.pour_through_funnel import PourThroughFunnelEnv

LEFT_YAW_TURN = -np.pi  # the left hand's yaw from the tab's direction: its wrist (link 6) out beyond the tab
ROLL_SIGN = -1.0  # the cup's roll about its pointing: the mouth swings back-left, the cup pours from front-right
CUP_GRASP_HEIGHT = 0.05  # the right TCP's height above the cup's bottom for its level side grasp
SOURCE_YAW = np.pi / 3  # the right gripper's pointing (as PourWaterBimanual's source)
PULL_OUT, PULL_STEP = 0.07, 0.005  # the funnel drawn straight up out of its stand this far, this much a step
LEFT_APPROACH = 0.1  # the left TCP lines up this far above the tab before moving down onto it
GRASP_RETRIES = 1  # pinches of the tab tried again when the funnel did not come out of its stand
FUNNEL_LIFT = 0.17  # the funnel's outlet this high above the table while carried (the bottle is 13.5 cm tall)
CUP_LIFT = 0.1
NECK_ABOVE = 0.02  # the outlet this far above the bottle's mouth before going down
NECK_DEPTH = 0.012  # the outlet this far below the bottle's mouth while pouring
SOURCE_BACK = 0.08  # the upright cup's mouth this far from the funnel's axis, against the pour direction
SOURCE_ABOVE = 0.11  # the cup's bottom this far above the funnel's rim while carried
MOUTH_ABOVE = 0.11  # the end of the cup mouth's path above the funnel's rim
POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS = 3.0, 50, 60
CLEAR = 0.015
POUR_OFFSET = 0.02  # the end of the cup mouth's path this far off the funnel's axis, away from its tab


def _pull_out(s: DrivenSolver, task: PourThroughFunnelEnv, q: torch.Tensor):
    """Draw the pinched funnel straight up PULL_OUT, PULL_STEP a control step."""
    start = s.tcp("left_arm").p.clone()
    up = torch.tensor([0.0, 0.0, PULL_OUT], device=task.device)
    glide(s, {"left_arm": (start, start + up, q)}, step_length=PULL_STEP, settle_steps=0)


def _outlet_servo(s: DrivenSolver, task: PourThroughFunnelEnv, goal: torch.Tensor, q: torch.Tensor, steps: int):
    """Drive the left TCP so that the funnel's measured outlet goes to `goal` (n, 3), `steps` control steps."""
    for _ in range(steps):
        s.step({"left_arm": (s.tcp("left_arm").p + goal - task.funnel.pose.p, q)})


@register_solver("PourThroughFunnel", control_modes=TCP_DELTA_MODES)
def solve_pour_through_funnel(env, seed: int) -> dict:
    """Left: top-down pinch across the funnel's tab, lift, outlet into the bottle's neck. Right: level grasp of
    the cup, lift, carry beside and above the funnel, roll its mouth over the funnel's."""
    with DrivenSolver.episode(env, seed) as s:
        task: PourThroughFunnelEnv = env.unwrapped
        n, device = task.num_envs, task.device
        # left: top-down across the tab, the hand turned half a turn from the tab's direction so that its wrist
        # (link 6) stands out beyond the tab, not over the funnel where the cup pours (measured: the cup hit it)
        lq = top_down_quat(yaw_of(task.funnel.pose.q) + LEFT_YAW_TURN, n, device)
        tab = task.tab_point()
        hold = Grasp("left_arm", "left_gripper", tab, lq, torch.tensor([0.0, 0.0, LEFT_APPROACH], device=device))
        pointing = torch.tensor([[np.cos(SOURCE_YAW), np.sin(SOURCE_YAW), 0.0]], device=device,
                                dtype=torch.float32).expand(n, 3)
        closing = ROLL_SIGN * torch.tensor([[np.sin(SOURCE_YAW), -np.cos(SOURCE_YAW), 0.0]], device=device,
                                           dtype=torch.float32).expand(n, 3)
        rq = tcp_quat(pointing, closing)
        cup_p = task.cup.pose.p + torch.tensor([0.0, 0.0, CUP_GRASP_HEIGHT], device=device)
        take = Grasp("right_arm", "right_gripper", cup_p, rq, -0.1 * pointing)
        s.move({"left_arm": (s.above(hold.lined_up[0], 0.1), lq), "right_arm": (s.above(take.lined_up[0], 0.1), rq)},
               max_steps=60)
        # the funnel has settled in its stand by now (it moves a few mm after the reset): aim at its tab from here
        lq = top_down_quat(yaw_of(task.funnel.pose.q) + LEFT_YAW_TURN, n, device)
        hold = Grasp("left_arm", "left_gripper", task.tab_point(), lq, hold.approach)
        reach(s, [hold, take], line_up_steps=30)
        grasp_together(s, ["left_gripper", "right_gripper"])
        # the funnel drawn slowly out of its stand (its neck 5 cm down the tube): yanked up at the arm's full
        # speed, a funnel settled a few degrees off caught the tube and was flung out of the pinch (seed 111)
        _pull_out(s, task, lq)
        for _ in range(GRASP_RETRIES):
            if bool(s.info["funnel_held"].all()):
                break
            # the pinch slipped off the tab (a funnel settled tilted, seed 113): it fell back into its stand;
            # open, rise, aim at the tab where it lies now, pinch and pull again
            s.release("left_gripper")
            s.move({"left_arm": (s.above(s.tcp("left_arm").p, LEFT_APPROACH), lq)}, max_steps=20)
            lq = top_down_quat(yaw_of(task.funnel.pose.q) + LEFT_YAW_TURN, n, device)
            hold = Grasp("left_arm", "left_gripper", task.tab_point(), lq, hold.approach)
            reach(s, [hold], line_up_steps=30)
            s.grasp("left_gripper")
            _pull_out(s, task, lq)
        if not bool(s.info["funnel_held"].all()):
            # no funnel in the pinch after the retries: the carries below follow a funnel lying loose and ran the
            # episode on to 725-2249 steps with nothing poured (seeds 101, 115, 148); end it here, failed
            return s.info
        # lift both: the funnel's outlet to FUNNEL_LIFT, the cup by CUP_LIFT
        left_up = s.tcp("left_arm").p.clone()
        left_up[:, 2] += FUNNEL_LIFT - task.funnel.pose.p[:, 2]
        s.move({"left_arm": (left_up, lq), "right_arm": (cup_p + torch.tensor([0, 0, CUP_LIFT], device=device), rq)},
               max_steps=40, pos_tol=0.01)
        # the funnel over the bottle, its outlet NECK_ABOVE above the mouth, then down into the neck
        mouth = task.bottle_mouth()
        above = mouth + torch.tensor([0.0, 0.0, NECK_ABOVE], device=device)
        held = s.tcp("left_arm").p - task.funnel.pose.p
        start = task.funnel.pose.p.clone()
        over = above.clone()
        over[:, 2] = torch.maximum(start[:, 2], above[:, 2])
        glide(s, {"left_arm": (start + held, over + held, lq)}, step_length=0.012, settle_steps=5)
        _outlet_servo(s, task, above, lq, 15)
        _outlet_servo(s, task, mouth - torch.tensor([0.0, 0.0, NECK_DEPTH], device=device), lq, 20)
        # the cup beside and above the funnel
        f_rim = task.funnel.pose.p[:, 2] + task.funnel_shape.height
        axis = ROLL_SIGN * pointing
        pour_dir = torch.linalg.cross(axis, torch.tensor([[0.0, 0.0, 1.0]], device=device).expand_as(pointing))
        held_r = s.tcp("right_arm").p - task.cup.pose.p
        goal_r = task.funnel.pose.p - SOURCE_BACK * pour_dir + held_r
        goal_r[:, 2] = f_rim + SOURCE_ABOVE + held_r[:, 2]
        glide(s, {"right_arm": (s.tcp("right_arm").p, goal_r, rq)}, step_length=0.012, settle_steps=15)
        f_mouth = task.funnel.pose.p + quaternion_apply(
            task.funnel.pose.q, torch.tensor([[-POUR_OFFSET, 0.0, task.funnel_shape.height + MOUTH_ABOVE]],
                                             device=device))
        steer_roll(s, task, "right_arm", axis, rq, f_mouth, f_rim, POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS,
                   CLEAR)
        s.hold_until_success(max_steps=40)
        return s.info
