"""Scripted solver of CoilRopeOnSpool (tasks/rope/coil_rope_on_spool.py): the left gripper holds the spool's crank
knob and turns it round the axle while the right gripper holds the rope near its free end, up at the drum's
height on the line along which the rope leaves the drum, and follows it in as it winds on; then both let go.

1. The left gripper grasps the crank knob top-down (`KNOB_GRIP_BELOW_TOP` below its top).
2. The right gripper grasps the capsule `GRASP_FROM_END` from the rope's free end top-down, fingers across it,
   lifts it to the feed height and carries it onto the rope's line (the drum's tangent at the tie, in the rope's
   heading), `SLACK` short of the rope's length there, so the rope hangs nearly taut from the drum.
3. Turn: each control step the left TCP is sent `LEAD` ahead (in the winding sense) of the knob's bearing round
   the axle, on the crank circle; the right TCP goes to where the free rope (from where it leaves the spool to
   the grasped capsule) reaches along the line, `FEED_SLACK` short, at the height where the rope is laid on the
   drum (rising `PITCH` rope diameters a turn, kept `TOP_CLEARANCE` under the top flange) plus `FEED_SLOPE` of
   its distance out; until the rope's coil reaches `min_turns` + `MARGIN_TURNS` (or `MAX_TURN_STEPS`; the feed
   point comes no nearer than `CLOSEST` to the axle).
4. The right gripper opens and lifts away; the left gripper opens and lifts off the knob.
5. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, grasp_together, reach
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.deformables import rope
from maniladder_ms.tasks.rope.coil_rope_on_spool import CoilRopeOnSpoolEnv

KNOB_GRIP_BELOW_TOP = 0.015  # the left TCP this far below the knob's top: finger tips clear of the top flange
GRASP_FROM_END = 1  # the right gripper grasps this capsule counted from the free end (0: the last)
GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
SLACK = 0.03  # metres of rope left slack between the drum and the grasp when it reaches the line
LIFT_STEP = 0.01  # metres a control step while carrying the rope onto the line
LEAD = 0.2  # rad: the crank target leads the knob's bearing by this (0.35: the spool turned faster than the feed)
# the feeding TCP aims this far short of where the rope reaches: at 1 cm the rope sagged onto the bottom flange
# between the hands, at -4 mm (pulled taut) the hands pulled against each other and the crank stalled
FEED_SLACK = 0.005
PITCH = 1.0  # rope diameters the feed height rises per turn laid on
TOP_CLEARANCE = 0.004  # ... up to this far below the top flange
# the feeding TCP is this much higher than the laid rope per metre out from the drum: the rope runs up to the
# hand, clear of the bottom flange's rim
FEED_SLOPE = 0.15
MARGIN_TURNS = 0.25  # wind this far past the rule's turns (the freed tail settles back a little)
CLOSEST = 0.09  # the feeding TCP stops this far from the axle (the crank hand circles above the drum)
MAX_TURN_STEPS = 260
RETREAT_HEIGHT = 0.08  # the open grippers lift this far


@register_solver("CoilRopeOnSpool", control_modes=TCP_DELTA_MODES)
def solve_coil_rope_on_spool(env, seed: int) -> dict:
    """Left hand on the crank, right hand holds the rope on the drum's tangent line at the drum's height; turn the
    crank while the right hand follows the rope in; let go."""
    with DrivenSolver.episode(env, seed) as s:
        task: CoilRopeOnSpoolEnv = env.unwrapped
        n, device = task.num_envs, task.device
        sp, cfg = task.spool, task.ROPE
        axis = sp.axis_xy()
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)

        def at(xy: torch.Tensor, z) -> torch.Tensor:
            z = torch.as_tensor(z, dtype=torch.float32, device=device).reshape(-1, 1).expand(xy.shape[0], 1)
            return torch.cat([xy, z], dim=1)

        # 1-2. knob (left) and rope (right) grasps, together
        knob = sp.knob.pose.p.clone()
        knob[:, 2] = sp.shape.knob_top - KNOB_GRIP_BELOW_TOP
        q_knob = top_down_quat(torch.zeros(n, device=device), n, device)
        g = cfg.segments - 1 - GRASP_FROM_END
        link = task.rope.links[g]
        yaw = DrivenSolver.neutral_yaw(rope.segment_yaw(link.pose.q), np.pi)
        q_rope = top_down_quat(yaw, n, device)
        grip_at = link.pose.p.clone()
        grip_at[:, 2] = cfg.radius + GRASP_CLEARANCE
        reach(s, [Grasp("left_arm", "left_gripper", knob, q_knob, above),
                  Grasp("right_arm", "right_gripper", grip_at, q_rope, above)])
        grasp_together(s, ["left_gripper", "right_gripper"])
        # the rope's line: from the tie's tangent point along the rope's heading
        tie = task.rope.links[0].pose
        heading = rope.segment_axis(tie.q)[:, :2]
        heading = torch.nn.functional.normalize(heading, dim=1)
        tangent_at = tie.p[:, :2]
        feed_z = sp.tie_height
        start = tangent_at + heading * (g * cfg.segment_length - SLACK)
        here = s.tcp("right_arm").p
        lift = at(here[:, :2], feed_z)
        s.move({"right_arm": (lift, q_rope)}, max_steps=20, pos_tol=0.005)
        steps = int(np.ceil(float(torch.linalg.norm(start - here[:, :2], dim=1).max()) / LIFT_STEP))
        for k in range(1, steps + 1):
            s.step({"right_arm": (at(here[:, :2] + (start - here[:, :2]) * k / steps, feed_z), q_rope)})
        s.move({"right_arm": (at(start, feed_z), q_rope)}, max_steps=15, pos_tol=0.005)
        def free_rope() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
            """Where the rope leaves the spool (its first point off it: how far along the line, its height) and its
            length from there to the grasped capsule, each (n,)."""
            points = task.rope.points()[:, :g + 2]
            rel = points[..., :2] - axis[:, None]
            on = ((torch.linalg.norm(rel, dim=-1) <= sp.shape.flange_radius)
                  & (points[..., 2] >= sp.shape.drum_bottom) & (points[..., 2] <= sp.shape.drum_top))
            leave = torch.cumprod(on.long(), dim=1).sum(dim=1).clamp(max=g + 1)  # index of the first point off it
            seg = torch.linalg.norm(points[:, 1:] - points[:, :-1], dim=-1)
            k = torch.arange(seg.shape[1], device=device)
            beyond = (seg * (k[None] >= leave[:, None])).sum(dim=1)
            at_leave = points[torch.arange(n, device=device), leave]
            return ((at_leave[:, :2] - tangent_at) * heading).sum(dim=1), at_leave[:, 2], beyond

        # 3. turn the crank clockwise (the rope leaves the drum counter-clockwise: the spool winds as it turns back)
        goal = task.min_turns + MARGIN_TURNS
        for _ in range(MAX_TURN_STEPS):
            coil = sp.turns()
            if bool((coil >= goal).all()):
                break
            rel = sp.knob.pose.p[:, :2] - axis
            bearing = torch.atan2(rel[:, 1], rel[:, 0]) - LEAD
            crank = at(axis + sp.shape.crank_radius * torch.stack([torch.cos(bearing), torch.sin(bearing)], 1),
                       knob[:, 2])
            # the feeding TCP where the free rope, `FEED_SLACK` short, reaches from where it leaves the spool, at the
            # height the slope asks
            along, leave_z, beyond = free_rope()
            reach_out = (beyond - FEED_SLACK).clamp(min=0)
            lay_z = (feed_z + 2 * cfg.radius * PITCH * coil).clamp(max=sp.shape.drum_top - cfg.radius - TOP_CLEARANCE)
            z = lay_z + FEED_SLOPE * (along + reach_out)
            rise = (z - GRASP_CLEARANCE - leave_z).clamp(min=0)
            d = (along + torch.sqrt((reach_out ** 2 - rise ** 2).clamp(min=0))).clamp(min=CLOSEST)
            s.step({"left_arm": (crank, q_knob), "right_arm": (at(tangent_at + heading * d[:, None], z), q_rope)})
        # 4. let go of the rope, then of the crank
        s.grip(False, "right_gripper", steps=8)
        s.move({"right_arm": (s.above(s.tcp("right_arm").p, RETREAT_HEIGHT), q_rope)}, max_steps=15)
        s.grip(False, "left_gripper", steps=8)
        s.move({"left_arm": (s.above(s.tcp("left_arm").p, RETREAT_HEIGHT), q_knob)}, max_steps=15)
        s.hold_until_success()
        return s.info
