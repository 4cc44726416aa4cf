"""Scripted solver of ScoopBeansWithSpoon (tasks/particles/scoop_beans/scoop_beans_with_spoon.py): grasp the spoon's
handle, drag its tilted head through the pile, carry the load front up to the cup and tip it in; a second scoop if
the first delivered too few. Every phase servoes the spoon's pose through the grip measured after the grasp.

1. grasp the handle top-down HANDLE_GRASP_BACK behind the head and lift; measure the grip (the TCP in the spoon's
   frame: the spoon sits a little off the TCP);
2. over the bowl, tilt the head DIG_TILT front down and lower its front edge into the near side of the pile;
3. drag the edge through the pile to DRAG_END, DIG_HEIGHT over the floor and WALL_CLEAR over the far wall;
4. turn the head about its edge to CARRY_TILT, then lift it to CARRY_HEIGHT turning it to LIFT_TILT (front up);
5. carry it level over the cup and tip it to TIP, the front edge over the cup's centre, until the beans roll out;
6. if fewer than `min_beans` landed: out of the cup, back over the bowl, measure the grip again (the tip turns the
   spoon a few degrees in the fingers) and repeat 2-5 (PASSES scoops in all).
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion, quaternion_apply, quaternion_multiply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.particles.scoop_beans.scoop_beans_with_spoon import ScoopBeansWithSpoonEnv

DIG_TILT = np.radians(25)  # front down while digging into the pile
CARRY_TILT = np.radians(-10)  # front slightly up as the head turns out of the pile
# front up while lifting and carrying: past the bevel's 14 degrees, so the beans roll back off it onto the flat
# plate (at -10 degrees the bevel still slopes front down and the beans on it slid off the open front in the
# carry: seed 102 carried 8 and delivered 6; at -25 the carried beans all reach the cup)
LIFT_TILT = np.radians(-25)
DIG_START = 0.03  # the head's centre starts this far before the bowl's centre (along the spoon)
DRAG_END = 0.06  # the front edge is dragged to this far past the bowl's centre (up the far wall)
DRAG_STEPS = 50
DIG_HEIGHT = 0.001  # the plate's front edge this high over the bowl's floor
WALL_CLEAR = 0.003  # and this high over the wall under its corners
SCOOP_STEPS = 16
SCOOP_FORWARD = 0.0
SCOOP_RISE = 0.0
CARRY_HEIGHT = 0.13  # the head's plate this high over the table while carrying
TIP = np.radians(60)
TIP_STEPS = 30
CARRY_STEPS = 30
LIFT_STEPS = 15
# scoops: one carries 8-14 beans out of this pile (seeds 100-109), so a second one follows when the first did not
# deliver `min_beans`
PASSES = 2


def _rotation(axis: torch.Tensor, angle: float) -> torch.Tensor:
    return axis_angle_to_quaternion(axis * angle)


@register_solver("ScoopBeansWithSpoon", control_modes=TCP_DELTA_MODES)
def solve_scoop_beans_with_spoon(env, seed: int) -> dict:
    """Grasp the handle top-down behind the head; tilt the head front down, lower it into the near side of
    the pile and drag it through to the far side; turn it front up, lift and carry it over the cup; tip it
    front down until the beans roll out over the lip. If fewer than `min_beans` landed, lift out of the cup,
    go back over the bowl and scoop again. Every phase servoes the spoon's pose through the grip measured
    after the grasp (the spoon sits in the fingers a little off the TCP), measured again before the second
    scoop (the tip turns the spoon a few degrees in the fingers)."""
    with DrivenSolver.episode(env, seed) as s:
        task: ScoopBeansWithSpoonEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.spoon_shape
        grasp_local = torch.tensor([[shape.back_x - task.HANDLE_GRASP_BACK, 0.0, shape.handle_z]], device=device)
        grasp = (task.spoon.pose * Pose.create_from_pq(grasp_local.expand(n, 3))).p
        spoon_yaw = yaw_of(task.spoon.pose.q)
        s.pick("arm", "gripper", grasp, DrivenSolver.neutral_yaw(spoon_yaw, np.pi), lift=0.08)
        d = torch.stack([torch.cos(spoon_yaw), torch.sin(spoon_yaw), torch.zeros_like(spoon_yaw)], dim=1)
        axis = torch.cross(torch.tensor([[0.0, 0.0, 1.0]], device=device).expand(n, 3), d, dim=1)  # +angle: front down
        # the grasp as the fingers hold it (the spoon sits a little off the TCP): the TCP in the spoon's frame
        grip = [task.spoon.pose.inv() * s.tcp("arm")]
        level_q = task.spoon.pose.q.clone()

        def servo(point_local, target: torch.Tensor, tilt: float, steps: int, tol: float = 0.004):
            """Move the spoon (its point `point_local`) to `target` [n, 3] with the head tilted by `tilt`:
            the TCP goes where the grasp puts it for that spoon pose (open loop through the grip: chasing
            the measured spoon while it presses on beans or the bowl would twist it in the fingers)."""
            q = quaternion_multiply(_rotation(axis, tilt), level_q)
            t = torch.as_tensor(point_local, dtype=torch.float32, device=device).expand(n, 3)
            spoon = Pose.create_from_pq(target - quaternion_apply(q, t), q)
            tcp = spoon * grip[0]
            s.move({"arm": (tcp.p, tcp.q)}, max_steps=steps, pos_tol=tol)

        bowl = task.bowl.pose.p
        edge = [shape.front_x, 0.0, 0.0]
        # the front edge's path: along the spoon through the bowl's middle, DIG_HEIGHT over the floor and,
        # out where the wall rises, that wall's height under the edge's corners plus a few millimetres
        wall_r = np.array([r for _, r in task.bowl_shape.inner])
        wall_z = np.array([z for z, _ in task.bowl_shape.inner])
        half_w = shape.head_half[1] + shape.rim

        def edge_at(along: float) -> torch.Tensor:
            r = float(np.hypot(along, half_w))
            z = max(task.bowl_shape.floor + DIG_HEIGHT, float(np.interp(r, wall_r, wall_z)) + WALL_CLEAR)
            p = bowl + d * along
            p[:, 2] = z
            return p

        def scoop_and_tip(again: bool):
            start = bowl - d * DIG_START
            above = start.clone()
            above[:, 2] = task.bowl_shape.height + 0.05
            if again:  # out of the cup, back over the bowl; the tip may have turned the spoon in the fingers
                out = task.cup.pose.p.clone()
                out[:, 2] = CARRY_HEIGHT + 0.04
                servo(edge, out, 0.0, 20, 0.01)
                high = above.clone()
                high[:, 2] = CARRY_HEIGHT + 0.04
                servo([0.0, 0.0, 0.0], high, 0.0, 40, 0.01)
                grip[0] = task.spoon.pose.inv() * s.tcp("arm")
            servo([0.0, 0.0, 0.0], above, DIG_TILT, 60, 0.01)
            first = -DIG_START + shape.front_x * np.cos(DIG_TILT)
            servo(edge, edge_at(first), DIG_TILT, 40)
            for k in range(1, DRAG_STEPS + 1):
                servo(edge, edge_at(first + (DRAG_END - first) * k / DRAG_STEPS), DIG_TILT, 1)
            # scoop up along the far wall: the edge rises and the head turns level (then front up)
            end = edge_at(DRAG_END)
            for k in range(1, SCOOP_STEPS + 1):  # turn about the edge, which rises a little up the wall
                f = k / SCOOP_STEPS
                target = end + d * SCOOP_FORWARD * f
                target[:, 2] += SCOOP_RISE * f
                servo(edge, target, DIG_TILT + (CARRY_TILT - DIG_TILT) * f, 1)
            servo(edge, target, CARRY_TILT, 10, 0.003)
            up = target.clone()
            up[:, 2] = CARRY_HEIGHT
            for k in range(1, LIFT_STEPS + 1):  # slowly: a fast lift shakes the top of the heap off
                servo(edge, target + (up - target) * k / LIFT_STEPS,
                      CARRY_TILT + (LIFT_TILT - CARRY_TILT) * k / LIFT_STEPS, 1)
            servo(edge, up, LIFT_TILT, 10, 0.01)
            over = task.cup.pose.p.clone()
            over[:, 2] = CARRY_HEIGHT
            for k in range(1, CARRY_STEPS + 1):  # a steady carry: the wrist keeps the head's tilt
                servo(edge, up + (over - up) * k / CARRY_STEPS, LIFT_TILT, 1)
            servo(edge, over, LIFT_TILT, 20, 0.005)
            # tip: the front edge stays over the cup's centre
            target = task.cup.pose.p.clone()
            target[:, 2] = task.cup_shape.height + 0.03
            for k in range(1, TIP_STEPS + 1):
                servo(edge, target, LIFT_TILT + (TIP - LIFT_TILT) * k / TIP_STEPS, 1)
                if bool(s.info["success"].all()):
                    return

        for k in range(PASSES):
            scoop_and_tip(k > 0)
            s.hold_until_success(max_steps=10)  # the last beans are still falling into the cup
            if bool(s.info["success"].all()):
                break
        s.hold_until_success()
        return s.info
