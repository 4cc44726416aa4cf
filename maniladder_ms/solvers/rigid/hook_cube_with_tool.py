"""Scripted solver of HookCubeWithTool (tasks/rigid/hook_cube_with_tool.py): grasp the hook's handle, put the hook
down beside and behind the cube (`HookCubeWithToolEnv.behind_cube`), pull the cube straight back into the zone
(TCP deltas, the hook servoed closed loop through the grip as it sits in the fingers).

1. Pick: grasp the handle top-down `GRASP_FROM_END` from its near end, fingers across it, and lift the hook to
   `CARRY_Z`.
2. Carry: servo the hook's origin over the point behind the cube at `CARRY_Z`.
3. Lower: servo it down to `LOWERED_Z`, its pulling face beyond the cube's far corner.
4. Pull: straight back at `PULL_STEP` a control step, with the grip as it is once the hook is down, until the
   cube (flat against the pulling face) is on the zone's centre; a last servo there; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.hook_cube_with_tool import HookCubeWithToolEnv

GRASP_FROM_END = 0.06  # the grasp on the handle, from its near end
GRASP_Z = 0.02  # TCP height of the grasp (the handle is 3 cm high)
CARRY_Z = 0.16  # the hook's centre height while it moves over the cube (clear of it with the handle pitched 15 deg in the grip)
LOWERED_Z = 0.024  # the hook's centre height while pulling (its bottom 9 mm above the table: a hook end
# dragging on the table rattles and kicks the cube sideways)
PULL_STEP = 0.004  # metres per control step of the pull


@register_solver("HookCubeWithTool", control_modes=TCP_DELTA_MODES)
def solve_hook_cube_with_tool(env, seed: int) -> dict:
    """Grasp the handle near its end top-down, carry the hook over and beyond the cube, lower it beside and
    behind the cube, pull straight back until the cube's centre is on the zone's."""
    with DrivenSolver.episode(env, seed) as s:
        task: HookCubeWithToolEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.hook_shape
        tool = task.tool.pose
        grasp = (tool * Pose.create_from_pq(torch.tensor([[GRASP_FROM_END - shape.handle_length / 2, 0.0, 0.0]],
                                                         device=device))).p
        grasp[:, 2] = GRASP_Z
        # fingers close across the handle: the TCP's x axis along it
        yaw = DrivenSolver.neutral_yaw(yaw_of(tool.q), np.pi)
        s.pick("arm", "gripper", grasp, yaw, lift=CARRY_Z - shape.height / 2)

        def tcp_for(tool_p: torch.Tensor, grip: Pose | None = None):
            """TCP target that puts the hook's origin at `tool_p`, level, the handle along +x, for the tool
            as it sits in the grip now (the handle pitches in the fingers under the hook's weight)."""
            grip = task.tool.pose.inv() * s.tcp("arm") if grip is None else grip
            target = Pose.create_from_pq(tool_p, level) * grip
            return target.p, target.q

        level = yaw_quat(torch.zeros(n, device=device))

        def servo(tool_p: torch.Tensor, max_steps: int, tol: float):
            """Drive the hook's origin to `tool_p` closed loop (re-reading the grip every control step)."""
            for _ in range(max_steps):
                s.step({"arm": tcp_for(tool_p)})
                if bool((torch.linalg.norm(task.tool.pose.p - tool_p, dim=1) < tol).all()):
                    return

        behind = task.behind_cube()
        carry, lowered = behind.clone(), behind.clone()
        carry[:, 2], lowered[:, 2] = CARRY_Z, LOWERED_Z
        servo(carry, 80, 0.01)
        servo(lowered, 40, 0.004)
        # pull: the pulling face ends one cube half beyond the zone centre (the cube flat against it)
        end = lowered.clone()
        end[:, 0] = task.zone.pose.p[:, 0] + task.cube_half - shape.pull_face_x
        # the grip as it is once the hook is down (re-reading it every step feeds the hook's rattle back)
        grip = task.tool.pose.inv() * s.tcp("arm")
        steps = max(1, round(float(torch.linalg.norm(end - lowered, dim=1).max()) / PULL_STEP))
        for k in range(1, steps + 1):
            s.step({"arm": tcp_for(lowered + (end - lowered) * k / steps, grip)})
        servo(end, 10, 0.003)
        s.hold_until_success()
        return s.info
