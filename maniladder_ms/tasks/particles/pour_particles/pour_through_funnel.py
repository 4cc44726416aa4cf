"""PourThroughFunnel (L3 deformable DG): one arm holds a funnel in a narrow bottle's neck, the other pours a cup of
liquid through it."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects import containers

from .base import CupToBowl, _uniform


@register_task("PourThroughFunnel")
class PourThroughFunnelEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the left gripper takes a funnel by its handle tab out of its stand and holds its neck in the neck
    of a narrow bottle; the right gripper picks up a cup of water and pours it into the funnel, through its neck
    into the bottle.

    **Randomisation:**
    - the bottle (glass, open, 13.5 cm tall: body outer radius 3 cm, neck outer radius 2.2 cm, bore 3.8 cm wide)
      stands at `BOTTLE_PLACEMENT`;
    - the funnel (mouth 9 cm wide inside, neck bore 2.2 cm wide and 3 cm long, 7.5 cm tall, ~30 g; a handle tab
      on its rim) rests by its cone in the conical seat of a stand (fixed, 6.5 cm tall) at `STAND_PLACEMENT`,
      turned about its axis so that its tab points within `FUNNEL_YAW` of `TAB_YAW` (to the left, +y);
    - the cup (plastic, inner radius 2.5 cm, 8 cm tall) stands to the right at `CUP_PLACEMENT`, holding the
      `particle_count` liquid particles (low-friction spheres, radius 4 mm) packed from its floor with a small
      random jitter.

    **Success:** at least `success_fraction` of the `particle_count` particles lie inside the bottle
    (`particles.fraction_inside`) AND passed through the funnel's neck on their way (episode memory
    `through_neck`, one flag a particle, latched by `particles.funnel_passage`: in the neck's bore at a step, or in
    the funnel at one step and below its outlet at the next); the left gripper holds the funnel and the right
    gripper the cup (`ee.holds`), now and on every step since the first particle landed in the bottle (episode
    memory `funnel_let_go`, `cup_let_go`: the PourParticles rule, `CupToBowl.held_pour_metrics`). Water poured
    straight into the bottle, or through a funnel left standing in it, does not count.

    **Level 3:** (against Level 2's PourWaterBimanual: the source rolled over a cup 6 cm wide held in the air, 6
    stages, ~240 steps) the receiver's mouth is 3.8 cm wide, reached only through a tool: the funnel, picked from
    its stand by a 1 cm thick tab, must be carried and its neck (2.8 cm wide outside) lowered into the bottle's neck
    with 5 mm of clearance on each side, and held there while the other arm pours; the water must find the
    funnel's 2.2 cm bore (2.75 particle diameters): 8 stages (tab grasp, lift out of the stand, carry, lower into
    the neck; side grasp of the cup, lift, carry above the funnel, roll), 70 % of the water through the neck.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.1, -0.32, 0.32)
    PARAMS = ("success_fraction", "particle_count")
    bowl_name = "bottle"
    bowl_shape = containers.bottle(radius=0.03, body_height=0.09, shoulder_height=0.02, neck_radius=0.022,
                                   neck_height=0.025, wall=0.003)
    bowl_color = (0.45, 0.7, 0.55, 1)
    bottle_density = 2500.0  # glass: ~0.25 kg, it stands firm when the funnel's neck brushes it
    funnel_name = "funnel"
    funnel_shape = containers.funnel()
    funnel_color = (0.95, 0.6, 0.2, 1)
    funnel_density = 1000.0  # plastic: ~30 g
    # the stand's conical seat has the funnel's outer slope: the cone sits in it flush, not on an edge (on a plain
    # tube's top edge the light funnel, its tab to one side, rocked and turned as it settled)
    stand_shape = containers.ring(radius=0.02, height=0.05, seat_height=0.015, seat_slope=(
        (funnel_shape.inner[2][1] - funnel_shape.inner[1][1]) / (funnel_shape.inner[2][0] - funnel_shape.inner[1][0])))
    # m: the funnel starts this far above its seat and drops onto it (settled after 15 idle steps, seeds 100-149:
    # from 2 mm, 3 of 50 popped to 8.5-18 degrees of tilt and one 2 cm across the seat; from 5 mm, the worst 9.4)
    REST_GAP = 0.005
    held_containers = {"funnel": "left", "cup": "right"}
    # layout ranges ((x low, x high), (y low, y high)), uniform
    BOTTLE_PLACEMENT = ((-0.1, -0.04), (-0.03, 0.03))
    STAND_PLACEMENT = ((-0.16, -0.1), (0.13, 0.19))
    CUP_PLACEMENT = ((-0.16, -0.1), (-0.26, -0.18))
    TAB_YAW = np.pi / 2  # the funnel's handle tab points to the left (+y), towards the left arm, within
    FUNNEL_YAW = 0.35  # rad either side
    placement = {"bowl": BOTTLE_PLACEMENT, "cup": CUP_PLACEMENT}

    @property
    def funnel_rest_height(self) -> float:
        """The funnel's frame (its neck's outlet) above the table while its cone rests on the stand's top edge."""
        f, ring = self.funnel_shape, self.stand_shape
        slope = (f.inner[2][1] - f.inner[1][1]) / (f.inner[2][0] - f.inner[1][0])
        seat_bottom, seat_radius = ring.inner[1]  # where the seat starts, on the tube's top
        contact = containers.funnel_neck_top(f) + (seat_radius - f.inner[1][1] - f.wall) / slope
        return seat_bottom - contact + self.REST_GAP

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.funnel = containers.build_funnel(self.scene, self.funnel_name, self.funnel_shape, self.funnel_color,
                                              density=self.funnel_density)
        self.stand = containers.build_ring_stand(self.scene, "funnel_stand", self.stand_shape, (0.5, 0.5, 0.55, 1))
        n = self.particle_count
        self.memory.value("in_funnel", n)  # 0/1 a particle: inside the funnel at the last step
        self.memory.value("through_neck", n)  # 0/1 a particle, latched: it went through the funnel's neck

    def _build_bowl(self):
        return containers.build_open_vessel(self.scene, self.bowl_name, self.bowl_shape, self.bowl_color,
                                            density=self.bottle_density)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        b = len(env_idx)
        with torch.device(self.device):
            (x_lo, x_hi), (y_lo, y_hi) = self.STAND_PLACEMENT
            stand = torch.stack([_uniform(b, x_lo, x_hi), _uniform(b, y_lo, y_hi), torch.zeros(b)], dim=1)
            yaw = self.TAB_YAW + _uniform(b, -self.FUNNEL_YAW, self.FUNNEL_YAW)
            self.stand.set_pose(Pose.create_from_pq(stand))
            funnel = stand + torch.tensor([0.0, 0.0, self.funnel_rest_height])
            self.funnel.set_pose(Pose.create_from_pq(funnel, yaw_quat(yaw)))

    def _update_memory(self):
        super()._update_memory()
        was_in = self.memory["in_funnel"] > 0.5
        in_funnel, through = particles.funnel_passage(self.particles.positions(), self.funnel.pose,
                                                      self.funnel_shape, was_in)
        self.memory.store("in_funnel", in_funnel.float())
        self.memory.store("through_neck", torch.maximum(self.memory["through_neck"], through.float()))

    def tab_point(self) -> torch.Tensor:
        """World position (B, 3) of the funnel's handle tab centre."""
        local = torch.tensor(containers.funnel_tab_pose(self.funnel_shape).p, dtype=torch.float32, device=self.device)
        return self.funnel.pose.p + quaternion_apply(self.funnel.pose.q, local.expand(self.num_envs, 3))

    def bottle_mouth(self) -> torch.Tensor:
        """World position (B, 3) of the centre of the bottle's mouth."""
        local = torch.tensor([0.0, 0.0, self.bowl_shape.height], device=self.device).expand(self.num_envs, 3)
        return self.bowl.pose.p + quaternion_apply(self.bowl.pose.q, local)

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   funnel_held=info["funnel_held"], cup_held=info["cup_held"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs(), funnel_pose=self.funnel.pose.raw_pose,
                       stand_pose=self.stand.pose.raw_pose)
        return obs

    def evaluate(self):
        metrics = self.held_pour_metrics()  # success on the bottle alone; funnel_held, cup_held, *_let_go
        p = self.particles.positions()
        # the funnel's neck reaches into the bottle's: a particle still in the funnel is not in the bottle yet
        in_funnel = self.funnel_shape.inside(p, self.funnel.pose)
        in_bottle = self.bowl_shape.inside(p, self.bowl.pose) & ~in_funnel
        through = self.memory["through_neck"] > 0.5
        poured_through = (in_bottle & through).float().mean(dim=1)
        neck_offset = self.funnel.pose.p - self.bottle_mouth()
        metrics.update(
            success=metrics["success"] & (poured_through >= self.success_fraction),
            fraction_in_bottle=in_bottle.float().mean(dim=1),
            fraction_through_neck=through.float().mean(dim=1),
            fraction_poured_through=poured_through,
            fraction_in_funnel=in_funnel.float().mean(dim=1),
            fraction_spilled=particles.fraction_spilled(p, [(self.bowl.pose, self.bowl_shape),
                                                            (self.cup.pose, self.cup_shape),
                                                            (self.funnel.pose, self.funnel_shape)]),
            neck_in_bottle=(torch.linalg.norm(neck_offset[:, :2], dim=1) < self.bowl_shape.rim_radius)
            & (neck_offset[:, 2] < 0),
            cup_lifted=self.cup.pose.p[:, 2] > 0.05,
        )
        return metrics

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # left: reach the tab, hold the funnel, its neck's outlet to the bottle's mouth; right: reach the cup,
        # hold it, lift it; then the water through the neck into the bottle, less what was spilled
        reach_tab = 1 - torch.tanh(5 * torch.linalg.norm(self.tab_point() - self.ee.tcp("left").p, dim=1))
        cup_mid = self.cup.pose.p + torch.tensor([0, 0, self.cup_shape.height / 2], device=self.device)
        reach_cup = 1 - torch.tanh(5 * torch.linalg.norm(cup_mid - self.ee.tcp("right").p, dim=1))
        held_f, held_c = info["funnel_held"].float(), info["cup_held"].float()
        to_neck = 1 - torch.tanh(10 * torch.linalg.norm(self.funnel.pose.p - self.bottle_mouth(), dim=1))
        reward = 0.5 * (reach_tab + reach_cup) + 0.5 * (held_f + held_c)
        reward += held_f * (to_neck + info["neck_in_bottle"].float()) + 0.5 * held_c * info["cup_lifted"]
        reward += 3 * info["fraction_poured_through"] * (1 - info["fraction_spilled"]) * held_f
        reward[info["success"]] = self.max_dense_reward
        return reward
