"""SqueezeClayBimanual (L1 deformable DG): squeeze a clay block narrower between two closed grippers."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import tcp_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.clay.base import ClayTask

SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
SQUEEZE_AXIS = (0.0, 1.0)  # world y, from one arm to the other


@register_task("SqueezeClayBimanual")
class SqueezeClayBimanualEnv(ClayTask, ManiLadderEnv):
    """**Task:** a block of clay (plastic: it keeps the shape it is pressed into) lies on the table between
    the two arms, its long side along the line between them; squeeze it from both sides with the closed
    grippers until it is narrower along that line.

    **Randomisation:** the block (3 x 5 x 3 particles on a 1.2 cm lattice, 3.6 x 6 x 3.6 cm, the 6 cm side
    along y) is scaled by a uniform factor in [1, 1.15] (`Clay.reset`), turned by a uniform yaw in
    [-10, 10] degrees, its centre uniform in x in [-0.15, -0.05], y in [-0.05, 0.05].

    **Success:** the clay's width along the squeeze axis (world y; `clay.width_along`, the particles'
    extent with their radius) is at most `max_width_ratio` of its width at the start, and at some step
    of the episode both grippers pressed on the clay at once (`ee.touches`, episode memory
    `squeezed_both`: squeezed from both sides, not pushed narrower by one arm).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 5
    TASK_REGION = (-0.22, 0.02, -0.15, 0.15)
    # block_half: the particle centres' half extents (3 x 5 x 3 particles, the long side along y)
    PARAMS = ("block_half", "max_width_ratio")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_block(self.block_half, self.clay_config.spacing))
        self.memory.flag("squeezed_both")  # both grippers pressed on the clay at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx, x=(-0.15, -0.05), y=(-0.05, 0.05), yaw=(-np.deg2rad(10), np.deg2rad(10)))

    def width(self, points: torch.Tensor) -> torch.Tensor:
        axis = torch.tensor(SQUEEZE_AXIS, device=self.device)
        return clay.width_along(points, axis, self.clay_config.radius)

    def side_faces(self) -> dict[str, torch.Tensor]:
        """Table points (z = 0) at the middle of the clay's current outermost extent on each arm's side, [B, 3]."""
        points = self.clay.positions()
        middle = points.mean(dim=1) * torch.tensor([1.0, 1.0, 0.0], device=self.device)
        y = points[..., 1]
        faces = {}
        for side, sign in SIDES.items():
            face = middle.clone()
            face[:, 1] = (y.amax(dim=1) if sign > 0 else y.amin(dim=1)) + sign * self.clay_config.radius
            faces[side] = face
        return faces

    def _update_memory(self):
        if self.memory["squeezed_both"].all():
            return  # latched for good: spare the contact queries (45 particles a side)
        touched = {side: self.ee.touches(self.clay.spheres, side) for side in SIDES}  # one contact pass a side
        self.memory.latch("squeezed_both", touched["left"] & touched["right"])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        if "state" in self.obs_mode:
            obs.update(clay_points=self.clay.positions().flatten(1), width_ratio=info["width_ratio"])
        return obs

    def evaluate(self):
        width_ratio = self.width(self.clay.positions()) / self.width(self.clay.start)
        squeezed_both = self.memory["squeezed_both"]
        return {"success": (width_ratio <= self.max_width_ratio) & squeezed_both, "width_ratio": width_ratio,
                "squeezed_both": squeezed_both}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        for side, face in self.side_faces().items():
            reward += 1 - torch.tanh(5 * torch.linalg.norm(face - self.ee.tcp(side).p, dim=1))
        squeeze = ((1 - info["width_ratio"]) / (1 - self.max_width_ratio)).clamp(0, 1)
        reward += 2 * squeeze
        reward[info["success"]] = self.max_dense_reward
        return reward


SQUEEZE_Z = 0.018  # TCP height while squeezing: the closed fingertips 1 cm above the table, over the block's side
FINGER_HALF = 0.01  # the closed fingers' half thickness along the squeeze
GAP = 0.02  # between the fingers and the clay before the squeeze
# The grippers' targets move in by SQUEEZE_STEP a control step towards each other, past the clay's
# centre by AIM_PAST of its start width (the arms push only as hard as their targets are far: aimed at
# the middle, they stall with the clay at 65%), until the clay is SQUEEZE_TO of its start width. Let go,
# it springs back by up to a yield distance (1.5 mm) per link across: 0.55 -> about 0.65 (the rule: 0.7)
AIM_PAST = 0.15
SQUEEZE_TO = 0.55
SQUEEZE_STEP = 0.004
MAX_SQUEEZE_STEPS = 40
RELEASE_BELOW = 0.6
# The hands are 6 cm thick along the squeeze (fingers closing along x: a hand is 20 cm long across its
# closing axis, two of those along y would collide long before the clay is squeezed): each leans out by
# this angle about x, fingertips in, so the hands stay apart when the fingertips are 4 cm apart
TILT = 0.35


@register_solver("SqueezeClayBimanual", control_modes=TCP_DELTA_MODES)
def solve_squeeze_clay_bimanual(env, seed: int) -> dict:
    """Both grippers close, go down beside the clay's two ends (fingers closing along x, hands leaning out),
    move in together along y until the clay is 55% of its start width, and back off if it stays narrow enough
    when it springs back (else they keep it squeezed)."""
    with DrivenSolver.episode(env, seed) as s:
        task: SqueezeClayBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        closing = torch.tensor([[1.0, 0.0, 0.0]], device=device).repeat(n, 1)
        qs = {}
        for side, sign in SIDES.items():  # fingers down and leaning in towards the clay
            pointing = torch.tensor([[0.0, -sign * np.sin(TILT), -np.cos(TILT)]], dtype=torch.float32, device=device)
            qs[side] = tcp_quat(pointing.repeat(n, 1), closing)
        past = task.width(task.clay.start) * AIM_PAST
        starts, ends = {}, {}
        for side, face in task.side_faces().items():
            sign = SIDES[side]
            start, end = face.clone(), face.clone()
            start[:, 1] += sign * (FINGER_HALF + GAP)
            end[:, 1] = task.clay.start[..., 1].mean(dim=1) - sign * (past - FINGER_HALF)
            start[:, 2] = end[:, 2] = SQUEEZE_Z
            starts[side], ends[side] = start, end
        for side in SIDES:
            s.grip(True, f"{side}_gripper", steps=0)
        s.move({f"{side}_arm": (s.above(p, APPROACH_HEIGHT), qs[side]) for side, p in starts.items()}, max_steps=60,
               pos_tol=0.01)
        s.move({f"{side}_arm": (p, qs[side]) for side, p in starts.items()}, max_steps=30)
        length = max(float((ends[side] - starts[side]).norm(dim=1).max()) for side in SIDES)
        steps = max(1, round(length / SQUEEZE_STEP))
        for k in range(1, MAX_SQUEEZE_STEPS + 1):
            s.step({f"{side}_arm": (starts[side] + (ends[side] - starts[side]) * min(k / steps, 1.0), qs[side])
                    for side in SIDES})
            if bool((s.info["width_ratio"] <= SQUEEZE_TO).all()):
                break
        # let go only if the clay stays narrow enough when it springs back; else keep it squeezed (the
        # clay's outer columns can slip past the 2 cm wide fingers and stall the squeeze above 0.6)
        if bool((s.info["width_ratio"] <= RELEASE_BELOW).all()):
            backs = {side: s.tcp(f"{side}_arm").p + torch.tensor([0.0, SIDES[side] * 0.04, 0.0], device=device)
                     for side in SIDES}
            s.move({f"{side}_arm": (backs[side], qs[side]) for side in SIDES}, max_steps=10, pos_tol=0.01)
            s.move({f"{side}_arm": (s.above(backs[side], 0.05), qs[side]) for side in SIDES}, max_steps=10,
                   pos_tol=0.02)
        s.hold_until_success()
        return s.info
