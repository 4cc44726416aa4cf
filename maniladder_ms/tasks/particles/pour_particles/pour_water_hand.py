"""PourWaterHand (L2 deformable SX): grasp a cup of liquid with the LEAP hand and pour it into a bowl."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects import containers

from .base import CupToBowl, base_inside

# arm joints 1-7 of the ready pose: the hand 10 cm above its line-up point for the middle of the cup's placement
# range, palm turned in (+y) for the side grasp (pinocchio IK, of 100 random starts the solution furthest from the
# joint limits: 0.94 rad). The thumb-low side grasp (the mirror image of PourGrainsHandToCup's pourer) puts
# joint 7 at 2.77 of its 2.90 rad limit for this right hand; the thumb-high one at -0.4 rad, with room for the roll
READY_ARM_JOINTS = (-0.888, 0.822, 0.009, -1.741, 0.775, 1.139, -0.388)


@register_task("PourWaterHand")
class PourWaterHandEnv(CupToBowl, ManiLadderEnv):
    """**Task:** pick up a cup of water standing on the table with the LEAP hand, carry it to a bowl and
    pour the water into the bowl.

    **Randomisation:**
    - the cup (inner radius 2.7 cm at the floor widening to 2.9 cm at the rim, 13 cm tall, ~50 g) stands
      to the right, x in `cup_x_range`, y in `cup_y_range`, holding 80 liquid particles (low-friction
      spheres, radius 4 mm) packed from its floor with a small random jitter;
    - the bowl (ceramic, inner radius 8 cm at the rim, 5 cm tall) stands to the left, x in `bowl_x_range`,
      y in `bowl_y_range`;
    - the arm starts in a ready pose (`READY_JOINTS`, plus the usual joint noise): the hand raised beside the
      cup, palm turned in for a side grasp.

    **Success:** at least `success_fraction` of the `particle_count` liquid particles lie inside the bowl's inner
    volume (below its rim, `particles.fraction_inside`), and at least `success_fraction` of them left the cup
    while the hand held it (`ee.holds`) with the cup's bottom at least `lift_height` above the table (episode
    memory `poured_held`: the most particles counted outside the cup on such a step); the cup is not in the
    bowl (its base's centre outside the bowl's rim circle, or above the rim): water poured from the lifted, held
    cup, not knocked or dropped out of it.

    **Level 2:** (against Level 1's SX deformables: LiftRopeHand, DragTowelHand and PokeClayHand each take one
    grasp or touch and one motion, 2 stages, ~100-150 steps) four stages (side grasp, lift, carry 20-30 cm, a
    controlled roll of ~140 degrees about the palm normal while steering the cup's mouth over the bowl) in one
    300-step horizon; the tilted cup must stay in a four-finger grip that it tends to slip out of, and the water
    must land within the bowl's 8 cm rim radius from a 13 cm cup held 6-10 cm above it: at most a quarter of
    the 80 particles may be spilled on the way or left in the cup (the scripted solver: 225-246 steps, mean
    237, 50/50 on seeds 100-149).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.1, -0.15, 0.25)
    PARAMS = ("success_fraction", "particle_count", "lift_height", "cup_x_range", "cup_y_range", "bowl_x_range",
              "bowl_y_range")
    READY_JOINTS = {f"panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS, 1)}
    # PourGrainsHandToCup's glass (a tall, slightly flared cup): tall enough for a LEAP side grasp below the water's surface
    cup_shape = containers.glass(bottom_radius=0.027, top_radius=0.029, height=0.13)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.value("poured_held", 1)

    def cup_held_up(self) -> torch.Tensor:
        """(B,) the hand holds the cup and its bottom is at least `lift_height` above the table."""
        return self.ee.holds(self.cup) & (self.cup.pose.p[:, 2] >= self.lift_height)

    def _update_memory(self):
        super()._update_memory()
        out = 1 - particles.fraction_inside(self.particles.positions(), self.cup.pose, self.cup_shape)
        held = self.cup_held_up()
        best = self.memory["poured_held"][:, 0]
        self.memory.store("poured_held", torch.where(held, torch.maximum(best, out), best)[:, None])

    def cup_in_bowl(self) -> torch.Tensor:
        """(B,) the cup's base centre is within the bowl's rim circle and below its rim."""
        return base_inside(self.cup.pose.p, self.bowl.pose, self.bowl_shape)

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, cup_grasped=info["cup_grasped"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        metrics = self.pour_metrics()
        poured_held = self.memory["poured_held"][:, 0]
        in_bowl = self.cup_in_bowl()
        metrics.update(
            success=metrics["success"] & (poured_held >= self.success_fraction) & ~in_bowl,
            poured_held=poured_held,
            cup_in_bowl=in_bowl,
            cup_grasped=self.ee.holds(self.cup),
            cup_lifted=self.cup.pose.p[:, 2] >= self.lift_height,
        )
        return metrics

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the cup, grasp, lift, carry beside the bowl; then the water poured while held and in the bowl
        mid = torch.tensor([0, 0, 0.06], device=self.device)
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.cup.pose.p + mid - self.ee.tcp().p, dim=1))
        grasped = info["cup_grasped"].float()
        carry = 1 - torch.tanh(5 * torch.linalg.norm((self.bowl.pose.p - self.cup.pose.p)[:, :2], dim=1))
        reward = reach + grasped + carry * grasped * info["cup_lifted"]
        reward += 2 * self.pour_reward(info) * info["poured_held"]
        reward[info["success"]] = self.max_dense_reward
        return reward
