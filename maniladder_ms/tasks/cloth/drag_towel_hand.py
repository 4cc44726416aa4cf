"""DragTowelHand (L1 deformable SX): pinch a towel corner with the LEAP hand and drag the towel onto a target."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS

ROWS = COLS = 8


@register_task("DragTowelHand")
class DragTowelHandEnv(ManiLadderEnv):
    """**Task:** a towel lies flat on the table and a round target is marked beside it; pinch a corner of
    the towel with the LEAP hand and drag the towel over the table until its centre lies on the target.

    **Randomisation:**
    - the towel (`cloth.towel(8, 8)`: 2.5 cm particle spacing, particles of 1 cm radius, 17.5 cm between
      corner centres) lies flat, its centre at x uniform in [-0.12, -0.04], y uniform in [-0.08, 0.08],
      its edges turned by a yaw uniform in [-pi/4, pi/4);
    - the target's centre lies `drag` uniform in [0.12, 0.18] m from the towel's centre, in a direction
      uniform in [-3 pi / 4, 3 pi / 4) from +x (never towards the robot's base, where a top-down hand
      runs out of reach).

    **Success:** the towel's centroid (mean of its particle centres) is within `goal_radius` of the
    target's centre in the table plane; and the towel was dragged there by a corner: at some step the hand
    held (`ee.holds`) a corner particle while the centroid had come at least `drag_share` of its start
    distance towards the target (episode memory `dragged`).

    `is_grasped` (reward and observation only): the hand holds a corner particle (`ee.holds`; the
    solver's "scissor" pinch).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.34, 0.2, -0.3, 0.3)  # towel and target centres plus the towel's half diagonal
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("goal_radius", "drag_share")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(ROWS, COLS, self.cloth_config.spacing),
                                       self.cloth_config)
        self.corner_ids = self.towel.layout.named["corners"]
        self.target = build_zone_marker(self.scene, "target", self.goal_radius, (0.55, 0.85, 0.55, 1))
        self.corners = [self.towel.spheres[i] for i in self.corner_ids]
        self.memory.value("start_distance")
        self.memory.flag("dragged")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centre = torch.stack([torch.rand(b) * 0.08 - 0.12, torch.rand(b) * 0.16 - 0.08,
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) - 0.5) * (np.pi / 2)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))
            heading = (torch.rand(b) * 2 - 1) * (3 * np.pi / 4)
            drag = 0.12 + torch.rand(b) * 0.06
            target = centre + torch.stack([drag * torch.cos(heading), drag * torch.sin(heading), torch.zeros(b)], dim=1)
            target[:, 2] = MARKER_THICKNESS / 2
            self.target.set_pose(Pose.create_from_pq(target))
            self.memory.store("start_distance", self._distance()[env_idx, None], env_idx)

    def centroid(self) -> torch.Tensor:
        """Mean of the towel's particle centres, [B, 3]."""
        return self.towel.positions().mean(dim=1)

    def _distance(self) -> torch.Tensor:
        """From the towel's centroid to the target's centre in the table plane, [B]."""
        return torch.linalg.norm((self.target.pose.p - self.centroid())[:, :2], dim=1)

    def _update_memory(self):
        came = self._distance() <= (1 - self.drag_share) * self.memory["start_distance"][:, 0]
        self.memory.latch("dragged", came & self.ee.holds(self.corners))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, target_pos=self.target.pose.p, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(towel_points=self.towel.positions().flatten(1),
                       centroid_to_target=self.target.pose.p - self.centroid())
        return obs

    def evaluate(self):
        distance, dragged = self._distance(), self.memory["dragged"]
        return {"success": (distance <= self.goal_radius) & dragged, "distance": distance, "dragged": dragged,
                "is_grasped": self.ee.holds(self.corners)}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        corners = self.towel.positions()[:, self.corner_ids]
        reach = torch.linalg.norm(corners - self.ee.tcp().p[:, None], dim=-1).amin(dim=1)
        reward = 1 - torch.tanh(5 * reach) + info["is_grasped"].float()
        reward += 3 * (1 - torch.tanh(5 * info["distance"]))
        reward[info["success"]] = self.max_dense_reward
        return reward


DRAG_SPEED = 0.006  # m a control step


def leading_corner(task: DragTowelHandEnv) -> torch.Tensor:
    """Per env, the corner particle furthest along the way from the towel's centroid to the target, [B]."""
    points = task.towel.positions()
    corners = torch.tensor(task.corner_ids, device=points.device)
    way = (task.target.pose.p - task.centroid())[:, :2]
    along = (points[:, corners, :2] * way[:, None]).sum(dim=-1)
    return corners[along.argmax(dim=1)]


@register_solver("DragTowelHand", control_modes=TCP_DELTA_MODES)
def solve_drag_towel_hand(env, seed: int) -> dict:
    """Scissor-pinch the leading corner particle (index and middle straight down on either side of it,
    fingers along the towel's diagonal, swung together), drag it closed loop (every step the TCP target
    moves `DRAG_SPEED` along the centroid's remaining way to the target) until the centroid is within half
    the goal radius, open the fingers and lift the hand away."""
    with DrivenSolver.episode(env, seed) as s:
        task: DragTowelHandEnv = env.unwrapped
        points = task.towel.positions()
        corner = points[torch.arange(len(points), device=points.device), leading_corner(task)]
        tcp, q = DrivenSolver.corner_scissor_pose(corner, task.centroid(), task.cloth_config.radius)
        s.set_ee("hand", "scissor_open", steps=1)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
        s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        for _ in range(60):
            way = task.target.pose.p - task.centroid()
            way[:, 2] = 0
            length = torch.linalg.norm(way, dim=1, keepdim=True)
            if bool((length < task.goal_radius / 2).all()):
                break
            tcp = tcp + way * (DRAG_SPEED / length.clamp(min=DRAG_SPEED))
            s.step({"arm": (tcp, q)})
        s.set_ee("hand", "scissor_open", steps=5)
        s.move({"arm": (s.above(tcp, 0.06), q)}, max_steps=15, pos_tol=0.01)
        s.hold_until_success()
        return s.info
