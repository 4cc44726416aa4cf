"""PourWaterBimanual (L2 deformable DG): each gripper holds a cup; pour the liquid from one cup into the other."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import tilt
from maniladder_ms.objects import containers

from .base import CupToBowl


@register_task("PourWaterBimanual")
class PourWaterBimanualEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the left gripper picks up an empty cup and the right gripper a cup of water; holding both
    in the air, pour the water from the right cup into the left one and keep it upright.

    **Randomisation:**
    - the source cup (plastic, inner radius 2.5 cm, 8 cm tall, 5.8 cm wide outside) stands to the right,
      x in `source_cup_x_range`, y in `source_cup_y_range`, holding 80 liquid particles (low-friction spheres, radius
      4 mm) packed from its floor with a small random jitter;
    - the receiving cup (plastic, inner radius 3 cm, 8 cm tall, 6.8 cm wide outside), empty, stands to the
      left, x in `receiving_cup_x_range`, y in `receiving_cup_y_range`.

    **Success:** (`CupToBowl.held_pour_metrics`, the PourParticles rule, with the receiving cup in the
    bowl's role) at least `success_fraction` of the `particle_count` particles lie inside the receiving
    cup's inner volume (below its rim, `particles.fraction_inside`); the left gripper holds the receiving
    cup and the right gripper the source cup (`ee.holds`), now and on every step since the first particle
    landed in the receiving cup (episode memory `receiving_cup_let_go`, `source_cup_let_go`); on every such
    step the receiving cup's base was at least `lift_height` above the table (episode memory
    `poured_low`): the pour happened between two cups held in the air; and the receiving cup is upright
    now, its axis within `max_tilt` of vertical.

    **Level 2:** (against Level 1's PourWaterHoldBowl: the bowl stays on the table, 16 cm wide, steadied by
    a pinch on its rim, ~200 steps) both containers are in the air and both arms move: the left arm lifts
    the receiver at least 5 cm and holds it still and upright (within 15 degrees) while the right arm
    rolls the source cup 172 degrees above it; the receiver's mouth is 6 cm wide against the bowl's 16 cm,
    so the source's mouth must be steered to within ~2 cm of it while it turns, and a quarter of the water
    spilled fails: 6 stages (two level side grasps, lift both, bring the receiver to the middle, carry
    the source above it, roll) in a 300-step horizon (the scripted solver: 240-246 steps, 50/50 on seeds
    100-149).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.1, -0.32, 0.32)
    PARAMS = ("success_fraction", "particle_count", "lift_height", "max_tilt", "source_cup_x_range",
              "source_cup_y_range", "receiving_cup_x_range", "receiving_cup_y_range")
    cup_name = "source_cup"
    bowl_name = "receiving_cup"
    bowl_shape = containers.cup(radius=0.03, height=0.08, wall=0.004)
    bowl_density = CupToBowl.cup_density
    bowl_color = (0.85, 0.45, 0.35, 1)
    held_containers = {"bowl": "left", "cup": "right"}
    placement_roles = ("bowl", "cup")  # the receiving cup's place drawn first

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("poured_low")

    def _update_memory(self):
        super()._update_memory()
        pouring = particles.fraction_inside(self.particles.positions(), self.bowl.pose, self.bowl_shape) > 0
        self.memory.latch("poured_low", pouring & (self.bowl.pose.p[:, 2] < self.lift_height))

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   receiving_cup_held=info["receiving_cup_held"], source_cup_held=info["source_cup_held"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        metrics = self.held_pour_metrics()  # receiving_cup_held, source_cup_held, *_let_go
        receiver_tilt = tilt(self.bowl)
        upright = receiver_tilt <= np.deg2rad(self.max_tilt)
        poured_low = self.memory["poured_low"]
        metrics.update(
            success=metrics["success"] & upright & ~poured_low,
            receiver_upright=upright,
            receiver_tilt=receiver_tilt,
            poured_low=poured_low,
            receiver_lifted=self.bowl.pose.p[:, 2] >= self.lift_height,
            source_lifted=self.cup.pose.p[:, 2] >= self.lift_height,
            fraction_in_receiver=metrics["fraction_in_bowl"],
            fraction_in_source=metrics["fraction_in_cup"],
        )
        return metrics

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # each arm reaches and holds its cup; the receiver lifted and upright, the source lifted and above it;
        # then the water in the receiver
        mid = torch.tensor([0, 0, 0.05], device=self.device)
        reach_l = 1 - torch.tanh(5 * torch.linalg.norm(self.bowl.pose.p + mid - self.ee.tcp("left").p, dim=1))
        reach_r = 1 - torch.tanh(5 * torch.linalg.norm(self.cup.pose.p + mid - self.ee.tcp("right").p, dim=1))
        held_l, held_r = info["receiving_cup_held"].float(), info["source_cup_held"].float()
        lifted = held_l * info["receiver_lifted"] * info["receiver_upright"]
        carry = 1 - torch.tanh(5 * torch.linalg.norm((self.bowl.pose.p - self.cup.pose.p)[:, :2], dim=1))
        reward = 0.5 * (reach_l + reach_r) + 0.5 * (held_l + held_r) + 0.5 * lifted
        reward += 0.5 * carry * held_r * info["source_lifted"]
        reward += 2 * self.pour_reward(info) * lifted
        reward[info["success"]] = self.max_dense_reward
        return reward
