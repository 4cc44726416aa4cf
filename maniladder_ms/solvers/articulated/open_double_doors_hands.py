"""Scripted solver of OpenDoubleDoorsHands (tasks/articulated/open_double_doors_hands.py): each LEAP hand closes
round its door's knob post from above and both carry their grasps round the hinges together.

1. Both hands rise `TURN_CLEARANCE` where they are and turn to their grasp yaws there (turning while reaching can
   fold an arm into a tilted-hand posture it does not leave).
2. Both reach their knobs from `ABOVE_KNOB` above (`bimanual.reach`) and close round the posts together
   (`bimanual.grasp_together`).
3. Both carry their grasps round the hinges in `ARC_STEPS` steps to `OPEN_TO`, each hand turning with its door.
4. Hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.objects.cabinet import DOOR_SIDE, DOORS
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, grasp_together, reach
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.articulated.open_double_doors_hands import OpenDoubleDoorsHandsEnv

TURN_CLEARANCE, TURN_STEPS = 0.1, 40  # m the hands rise while turning to their grasp yaws; control steps at most
ABOVE_KNOB = 0.08  # m above the grasp where each hand lines up
OPEN_TO = np.deg2rad(90)  # past the 60-degree goal: the doors lag the hands by ~25 degrees
ARC_STEPS = 12  # targets along the arc
ARC_STEP_MAX_STEPS, ARC_POS_TOL = 4, 0.01  # each arc target's move: control steps at most, m


@register_solver("OpenDoubleDoorsHands", control_modes=TCP_DELTA_MODES)
def solve_open_double_doors_hands(env, seed: int) -> dict:
    """Both hands close round their doors' knob posts from above, then carry their grasps round the
    hinges together, each hand turning with its door."""
    with DrivenSolver.episode(env, seed) as s:
        task: OpenDoubleDoorsHandsEnv = env.unwrapped
        n, device = task.num_envs, task.device
        # in a door's frame: TCP on the knob's axis, fingers pointing along the door towards its hinge: the
        # wrists then turn with the doors within their joint ranges, and the fingers stay clear of the doors
        grasp_local = {door: Pose.create_from_pq(torch.zeros(1, 3, device=device),
                                                 top_down_quat(DOOR_SIDE[door] * np.pi / 2, 1, device=device))
                       for door in DOORS}

        def grasp_pose(door: str, angle: float) -> Pose:
            return task.grasp_frame(door, torch.full((n,), angle, device=device)) * grasp_local[door]

        up = torch.tensor([0.0, 0.0, ABOVE_KNOB], device=device)
        grasps = []
        for door in DOORS:
            pose = grasp_pose(door, 0.0)
            grasps.append(Grasp(f"{door}_arm", f"{door}_hand", pose.p, pose.q, up))
        s.move({g.arm: (s.above(s.tcp(g.arm).p, TURN_CLEARANCE), g.q) for g in grasps}, max_steps=TURN_STEPS)
        reach(s, grasps)
        grasp_together(s, [g.ee for g in grasps])
        for angle in np.linspace(0.0, OPEN_TO, ARC_STEPS + 1)[1:]:
            targets = {}
            for door in DOORS:
                pose = grasp_pose(door, float(angle))
                targets[f"{door}_arm"] = (pose.p, pose.q)
            s.move(targets, max_steps=ARC_STEP_MAX_STEPS, pos_tol=ARC_POS_TOL)
        s.hold_until_success()
        return s.info
