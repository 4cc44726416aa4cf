"""PourGrainsHandToCup (L1 deformable DX): one LEAP hand holds a cup, the other pours grains into it from a glass."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects import containers
from maniladder_ms.agents.poses import READY_ARM_JOINTS

from .base import CupToBowl

# The left hand pours and the right holds. Both take side grasps, palm level with the container, the finger row
# upright. The pourer's grasp needs its thumb low, under the glass' grains. For the right Panda that grasp puts
# joint 7 at 2.88 of its 2.90 rad limit: pinocchio IK finds no other solution with the elbow up, and servoing to
# it left the arm 0.5-0.6 rad short on ~30 % of seeds. For the left Panda, joint 7 is at -1.4 rad, with >= 0.8 rad
# to every limit over the reach, carry and roll. The right hand holds the cup with its thumb high (margin 0.96).
POURER, HOLDER = "left", "right"
# the ready pose (`agents.poses.READY_ARM_JOINTS`): each hand raised above its container, turned for its side
# grasp (the pourer's with the thumb low, the holder's high)


@register_task("PourGrainsHandToCup")
class PourGrainsHandToCupEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the right LEAP hand holds a cup standing on the table while the left LEAP hand picks up a
    glass of grains and pours them into the cup.

    **Randomisation:**
    - the cup (plastic, inner radius 3.5 cm, 11 cm tall, 7.8 cm wide outside) stands in front of the right
      arm, x in `cup_x_range`, y in `cup_y_range`;
    - the glass (inner radius 2.7 cm at the floor widening to 2.9 cm at the rim, 13 cm tall) stands to the
      left behind it, x in `glass_x_range`, y in `glass_y_range`, holding 60 grains (granular spheres, radius 4 mm)
      packed from its floor with a small random jitter;
    - the arms start in a ready pose (`READY_JOINTS`, plus the usual joint noise): each hand raised above its
      container, palm turned in for a side grasp.

    **Success:** (`CupToBowl.held_pour_metrics`, the PourParticles rule) at least `success_fraction` of the
    `particle_count` grains lie inside the cup's inner volume (below its rim, `particles.fraction_inside`); the right hand
    holds the cup (`cup_held`, `ee.holds`: a finger against the thumb or palm, or the scissor pinch) and
    the left hand the glass (`glass_grasped`), now and on every step since the first grain landed in the
    cup (episode memory `cup_let_go`, `glass_let_go`): the grains go into the held cup, poured from the
    held glass.

    (In `CupToBowl`'s terms the glass is the pouring `self.cup` and the held cup the receiving `self.bowl`.)
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.12, -0.25, 0.25)
    READY_JOINTS = {f"{side}_panda_joint{i}": angle for side in (POURER, HOLDER)
                    for i, angle in enumerate(READY_ARM_JOINTS[side], 1)}
    # tall enough for the LEAP hand's side grasp: the thumb closes low on it, the three fingers above
    cup_shape = containers.glass(bottom_radius=0.027, top_radius=0.029, height=0.13)
    bowl_shape = containers.cup(radius=0.035, height=0.11, wall=0.004)
    cup_name = "glass"
    bowl_name = "cup"
    PARAMS = ("success_fraction", "particle_count", "cup_x_range", "cup_y_range", "glass_x_range", "glass_y_range")
    particle_name = "grains"
    # the receiving cup (`self.bowl`) by the holder, the pouring glass (`self.cup`) by the pourer
    held_containers = {"bowl": HOLDER, "cup": POURER}
    bowl_density = CupToBowl.cup_density  # a light plastic cup, as the glass
    bowl_color = (0.8, 0.35, 0.3, 1)
    placement_roles = ("bowl", "cup")  # the receiving cup's place drawn first

    particle_material = particles.GRANULAR
    particle_radius = 0.004

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   cup_held=info["cup_held"], glass_grasped=info["glass_grasped"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        metrics = self.held_pour_metrics()  # cup_held, glass_held, cup_let_go, glass_let_go
        return {
            **metrics,
            "fraction_in_held_cup": metrics["fraction_in_bowl"],
            "fraction_in_glass": metrics["fraction_in_cup"],
            "glass_grasped": metrics["glass_held"],
            "glass_lifted": self.cup.pose.p[:, 2] > 0.05,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # holder: reach and hold the cup; pourer: reach the glass, grasp, lift, carry beside the cup; then the
        # grains in the cup
        mid = torch.tensor([0, 0, 0.04], device=self.device)
        reach_cup = 1 - torch.tanh(5 * torch.linalg.norm(self.bowl.pose.p + mid - self.ee.tcp(HOLDER).p, dim=1))
        reach_glass = 1 - torch.tanh(5 * torch.linalg.norm(self.cup.pose.p + mid - self.ee.tcp(POURER).p, dim=1))
        grasped = info["glass_grasped"].float()
        carry = 1 - torch.tanh(5 * torch.linalg.norm((self.bowl.pose.p - self.cup.pose.p)[:, :2], dim=1))
        reward = 0.5 * (reach_cup + info["cup_held"].float()) + 0.5 * reach_glass + grasped
        reward += carry * grasped * info["glass_lifted"]
        reward += 2 * self.pour_reward(info) * info["cup_held"]
        reward[info["success"]] = self.max_dense_reward
        return reward
