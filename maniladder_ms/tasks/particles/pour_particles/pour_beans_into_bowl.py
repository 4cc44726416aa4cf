"""PourBeansIntoBowl (L1 deformable SG): pick up a cup of beans and pour them into a bowl."""

from __future__ import annotations

import dataclasses
from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task

from .base import CupToBowl


@register_task("PourBeansIntoBowl")
class PourBeansIntoBowlEnv(CupToBowl, ManiLadderEnv):
    """**Task:** pick up a cup of beans and pour the beans into a bowl.

    **Randomisation:**
    - the cup (plastic, inner radius 2.5 cm, 8 cm tall, 5.8 cm wide outside) stands at x in `cup_x_range`,
      y in `cup_y_range` (the robot's left), holding `bean_count`
      beans (granular spheres of radius `bean_radius`; 80 of 4 mm: 4 layers) packed from its floor with a
      small random jitter;
    - the bowl (inner radius 8 cm at the rim, 5 cm tall) stands in front of it, x in `bowl_x_range`,
      y in `bowl_y_range`.

    **Success:** at least `success_fraction` of the beans lie inside the bowl's inner volume (below its
    rim, `particles.fraction_inside`), and they were poured from the held cup: the gripper holds the cup
    (`ee.holds`), the cup's mid-axis point is not inside the bowl, and the share of beans in the bowl
    exceeds by at least `success_fraction` the largest share seen in the bowl at any step the cup was not
    held (episode memory `in_bowl_unheld`: beans that reached the bowl from a knocked-over or dropped cup
    do not count).
    """

    max_dense_reward = 6

    TASK_REGION = (-0.2, 0.18, -0.25, 0.25)
    PARAMS = ("bean_count", "bean_radius", "success_fraction", "cup_x_range", "cup_y_range", "bowl_x_range",
              "bowl_y_range")
    particle_name = "beans"

    @property
    def particle_config(self) -> particles.ParticleConfig:
        return dataclasses.replace(particles.GRANULAR, count=self.bean_count, radius=self.bean_radius)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.value("in_bowl_unheld")

    def _in_bowl(self) -> torch.Tensor:
        return particles.fraction_inside(self.particles.positions(), self.bowl.pose, self.bowl_shape)

    def _update_memory(self):
        unheld = self.memory["in_bowl_unheld"][:, 0]
        in_bowl = torch.where(self.ee.holds(self.cup), unheld, torch.maximum(unheld, self._in_bowl()))
        self.memory.store("in_bowl_unheld", in_bowl[:, None])

    def cup_in_bowl(self) -> torch.Tensor:
        """The cup's mid-axis point lies inside the bowl's inner volume, [B]."""
        mid = self.cup.pose * Pose.create_from_pq(torch.tensor([[0.0, 0.0, self.cup_shape.height / 2]], device=self.device))
        return self.bowl_shape.inside(mid.p[:, None], self.bowl.pose)[:, 0]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        cup_up = self.cup.pose.to_transformation_matrix()[:, 2, 2]  # cos of the cup axis' tilt
        metrics, is_grasped, cup_in_bowl = self.pour_metrics(), self.ee.holds(self.cup), self.cup_in_bowl()
        in_bowl_unheld = self.memory["in_bowl_unheld"][:, 0]
        poured_while_held = metrics["fraction_in_bowl"] - in_bowl_unheld >= self.success_fraction
        return {
            **metrics,
            "success": metrics["success"] & is_grasped & ~cup_in_bowl & poured_while_held,
            "in_bowl_unheld": in_bowl_unheld,
            "cup_in_bowl": cup_in_bowl,
            "is_grasped": is_grasped,
            "is_lifted": self.cup.pose.p[:, 2] > 0.05,
            "is_tilted": cup_up < 0,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the cup's side at mid height, grasp, lift; carry it beside the bowl, tilt; beans in the bowl
        grasp_point = self.cup.pose.p + torch.tensor([0, 0, self.cup_shape.height / 2], device=self.device)
        reward = 1 - torch.tanh(5 * torch.linalg.norm(grasp_point - self.ee.tcp().p, dim=1))
        is_grasped = info["is_grasped"].float()
        reward += is_grasped
        above_bowl = self.bowl.pose.p + torch.tensor([0, 0, 0.15], device=self.device)
        carry = 1 - torch.tanh(5 * torch.linalg.norm((above_bowl - self.cup.pose.p)[:, :2], dim=1))
        reward += carry * is_grasped * info["is_lifted"]
        reward += 3 * self.pour_reward(info)
        reward[info["success"]] = self.max_dense_reward
        return reward
