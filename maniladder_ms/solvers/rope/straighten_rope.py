"""Scripted solver of StraightenRope (tasks/rope/straighten_rope.py): lay one end of the rope at the strip's near
end, then take the other end, lay it down on the strip's axis and pull it away along the axis until the rope is
taut and straight between the two ends.

1. Pick the end nearer the strip's near end (the strip end nearer the rope's centroid; the pull runs from there,
   along `axis`, to the far end): grasp the capsule `GRASP_FROM_END` in from it, top-down, fingers across it;
   drag it low (`CARRY_Z`) to `ANCHOR_AT` from the strip centre along -axis, lower it, let go, lift away.
2. Grasp the other end the same way, carry it low to `START_SPAN` past the laid end along the axis, lower it
   to the table.
3. Pull it along the axis, `PULL_STEP` a control step, until the rope's straightness reaches `TAUT` (or the end
   reaches `PULL_LIMIT` from the laid end's place along the axis); let go. If the rope is not straight then (the
   end slipped out of the fingers), take that end again and pull on (`REGRASPS` times at most).
4. Take the laid end again, drag it sideways onto the axis and back along it to `ANCHOR_AT` (the pull dragged it
   along, and dragging the whole rope back straightens what bow is left); let go, lift away.
5. If the pulled end now lies more than `OFF_AXIS` off the axis (the rope straight but slanted across the strip),
   take it again, put it onto the axis sideways and pull it along until straight; let go; hold still until
   success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rope.straighten_rope import StraightenRopeEnv

GRASP_FROM_END = 1  # grasp this capsule counted from the end (0: the end capsule)
GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
CARRY_Z = 0.03  # TCP height while dragging an end: the rest of the rope trails on the table
APPROACH = 0.04  # the gripper comes down onto a capsule from this far above it
DRAG_STEP = 0.012  # metres the TCP target advances a control step while dragging
ANCHOR_AT = 0.17  # the first grasped capsule is laid this far from the strip centre, along -axis
SWING_RADIUS = 0.3  # the second grasped capsule swings round the laid one at this distance (taut: 0.34)
PULL_STEP = 0.005  # metres a control step while pulling the rope taut
TAUT = 0.993  # stop pulling at this straightness
PULL_LIMIT = 0.44  # ... or when the pulled capsule is this far from the laid one along the axis
REGRASPS = 1  # times the pulled end is taken again when the rope is not yet straight after the pull
# the pulled end is set straight again when it lies this far off the strip's axis (half the strip is 2.5 cm; at
# 1.2 cm ropes that were already inside got the extra ~200 steps too, past the horizon on one sweep seed)
OFF_AXIS = 0.02
RETREAT_HEIGHT = 0.04  # the open gripper lifts this far off the laid rope
RELEASE_STEPS = 6  # control steps the gripper takes to open


@register_solver("StraightenRope", control_modes=TCP_DELTA_MODES)
def solve_straighten_rope(env, seed: int) -> dict:
    """Lay one end at the strip's near end, set the other down on the axis with slack, pull it along the axis
    until the rope is straight, let go."""
    with DrivenSolver.episode(env, seed) as s:
        task: StraightenRopeEnv = env.unwrapped
        device = task.device
        cfg = task.rope_config
        centre, yaw = task.strip_frame()
        centre = centre[:, :2]
        axis = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
        centroid = task.rope.points()[:, 1:-1, :2].mean(dim=1)
        # the pull runs away from the rope's side: axis points from the near strip end to the far one
        axis = torch.where(((centroid - centre) * axis).sum(dim=1, keepdim=True) > 0, -axis, axis)
        anchor = centre - ANCHOR_AT * axis
        n = cfg.segments
        first, last = GRASP_FROM_END, n - 1 - GRASP_FROM_END
        d_first = torch.linalg.norm(task.rope.links[first].pose.p[:, :2] - anchor, dim=1)
        d_last = torch.linalg.norm(task.rope.links[last].pose.p[:, :2] - anchor, dim=1)
        laid, pulled = (first, last) if bool(d_first[0] <= d_last[0]) else (last, first)

        def at(xy: torch.Tensor, z: float) -> torch.Tensor:
            return torch.cat([xy, torch.full((xy.shape[0], 1), z, device=device)], dim=1)

        def quat(yaw: torch.Tensor) -> torch.Tensor:
            return top_down_quat(yaw, yaw.shape[0], device=device)

        def nearest(yaw: torch.Tensor, to: torch.Tensor) -> torch.Tensor:
            """Of the grasp yaws equivalent to `yaw` (modulo pi: the capsule is symmetric), the one nearest `to`."""
            return to + torch.remainder(yaw - to + np.pi / 2, np.pi) - np.pi / 2

        def grasp_end(index: int) -> torch.Tensor:
            """Grasp the capsule `index` top-down, fingers across it, and lift it to the carry height; its yaw."""
            link = task.rope.links[index]
            q_yaw = DrivenSolver.neutral_yaw(rope.segment_yaw(link.pose.q), np.pi)
            grasp = link.pose.p.clone()
            grasp[:, 2] = cfg.radius + GRASP_CLEARANCE
            s.pick("arm", "gripper", grasp, q_yaw, lift=CARRY_Z - cfg.radius - GRASP_CLEARANCE, approach=APPROACH)
            return q_yaw

        def drag(goal_xy: torch.Tensor, yaw: torch.Tensor, step: float, z: float = CARRY_Z, turn_to=None, stop=None):
            """Move the TCP in a straight line to `goal_xy` at height `z`, `step` a control step, turning the held
            capsule from `yaw` to `turn_to` on the way (the capsule pointing the way the rope is pulled: a capsule
            pulled across its axis pivots in the fingers and slips out); returns the yaw reached."""
            start = s.tcp("arm").p[:, :2]
            end_yaw = yaw if turn_to is None else nearest(turn_to, yaw)
            steps = int(np.ceil(float(torch.linalg.norm(goal_xy - start, dim=1).max()) / step))
            yaw_k = yaw
            for k in range(1, steps + 1):
                if stop is not None and stop():
                    break
                yaw_k = yaw + (end_yaw - yaw) * k / steps
                s.step({"arm": (at(start + (goal_xy - start) * k / steps, z), quat(yaw_k))})
            return yaw_k

        def put_down(yaw: torch.Tensor):
            here = s.tcp("arm").p.clone()
            here[:, 2] = cfg.radius + GRASP_CLEARANCE
            s.move({"arm": (here, quat(yaw))}, max_steps=15, pos_tol=0.004)
            s.release("gripper", steps=RELEASE_STEPS)
            s.move({"arm": (s.above(here, RETREAT_HEIGHT), quat(yaw))}, max_steps=20)

        def heading(v: torch.Tensor) -> torch.Tensor:
            return torch.atan2(v[:, 1], v[:, 0])

        axis_yaw = heading(axis)
        # 1. the first end to the strip's near end
        yaw = grasp_end(laid)
        yaw = drag(anchor, yaw, DRAG_STEP)
        s.move({"arm": (at(anchor, CARRY_Z), quat(yaw))}, max_steps=10, pos_tol=0.004)
        put_down(yaw)
        laid_at = task.rope.links[laid].pose.p[:, :2]
        # 2. the other end straight away from the laid one, then round it on a circle (through the robot's
        # side of the laid end) onto the strip's axis, the held capsule pointing away from the laid end all the
        # way; then down onto the table
        yaw = grasp_end(pulled)
        bearing = heading(s.tcp("arm").p[:, :2] - laid_at)
        yaw = drag(laid_at + SWING_RADIUS * torch.stack([torch.cos(bearing), torch.sin(bearing)], dim=1), yaw,
                   DRAG_STEP, turn_to=bearing)
        turn = torch.remainder(axis_yaw - bearing + np.pi, 2 * np.pi) - np.pi  # the short way, in (-pi, pi]
        other = turn - torch.sign(turn) * 2 * np.pi  # the long way
        # of the two ways round, the one that keeps to lower x (the far side is out of the arm's reach)
        fractions = torch.linspace(0, 1, 16, device=device)
        reach = [(laid_at[:, :1] + SWING_RADIUS * torch.cos(bearing[:, None] + way[:, None] * fractions)).amax(dim=1)
                 for way in (turn, other)]
        turn = torch.where(reach[0] <= reach[1], turn, other)
        steps = int(np.ceil(float(turn.abs().max()) * SWING_RADIUS / DRAG_STEP))
        for k in range(1, steps + 1):
            angle = bearing + turn * k / steps
            s.step({"arm": (at(laid_at + SWING_RADIUS * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1),
                               CARRY_Z), quat(yaw + turn * k / steps))})
        yaw = yaw + turn
        along = ((laid_at - centre) * axis).sum(dim=1, keepdim=True)  # the laid end's place along the axis
        start = centre + (along + SWING_RADIUS) * axis  # on the axis, whatever the laid end's sideways offset
        s.move({"arm": (at(start, cfg.radius + GRASP_CLEARANCE), quat(yaw))}, max_steps=15, pos_tol=0.004)
        # 3. pull along the axis until straight
        limit = centre + (along + PULL_LIMIT) * axis
        straight = lambda: bool((rope.straightness(task.rope.points()) >= TAUT).all())  # noqa: E731
        drag(limit, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, stop=straight)
        put_down(yaw)
        for _ in range(REGRASPS):  # the end slipped out of the fingers short of straight: take it again, pull on
            if straight():
                break
            yaw = grasp_end(pulled)
            yaw = drag(s.tcp("arm").p[:, :2], yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, turn_to=axis_yaw)
            yaw = drag(limit, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, stop=straight)
            put_down(yaw)
        # 4. the laid end back onto the axis (sideways), then pulled back along it to where it was laid: the pull
        # dragged it along, and dragging the whole rope back straightens what bow is left
        yaw = grasp_end(laid)
        here = s.tcp("arm").p[:, :2]
        on_axis = centre + ((here - centre) * axis).sum(dim=1, keepdim=True) * axis
        yaw = drag(on_axis, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, turn_to=axis_yaw)
        yaw = drag(anchor, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE)
        put_down(yaw)
        # 5. the pulled end, if it trails off the axis: onto the axis sideways, then along it until straight
        end = task.rope.links[pulled].pose.p[:, :2]
        across = ((end - centre) * torch.stack([-axis[:, 1], axis[:, 0]], dim=1)).sum(dim=1)
        if bool((across.abs() > OFF_AXIS).any()):
            yaw = grasp_end(pulled)
            here = s.tcp("arm").p[:, :2]
            on_axis = centre + ((here - centre) * axis).sum(dim=1, keepdim=True) * axis
            yaw = drag(on_axis, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, turn_to=axis_yaw)
            drag(centre + ANCHOR_AT * axis, yaw, PULL_STEP, z=cfg.radius + GRASP_CLEARANCE, stop=straight)
            put_down(yaw)
        s.hold_until_success()
        return s.info
