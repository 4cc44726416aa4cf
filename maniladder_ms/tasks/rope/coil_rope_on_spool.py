"""CoilRopeOnSpool (L3 deformable DG): one arm turns a spool by its crank while the other feeds the rope onto it."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.deformables import rope, spool
from maniladder_ms.envs import ManiLadderEnv, register_task


@register_task("CoilRopeOnSpool")
class CoilRopeOnSpoolEnv(ManiLadderEnv):
    """**Task:** a spool stands on the table on the left arm's side: a drum between two wide flanges (a reel),
    turning freely on a vertical axle, with a crank knob on its top flange; a rope is tied to the drum and runs off
    it over the bottom flange's rim and across the table towards the right arm. Coil the rope onto the spool: one
    gripper turns the spool by its crank while the other holds the rope up between the flanges and follows it in
    as it winds on; then let go of it.

    **Randomisation:**
    - the spool (`SPOOL`, a `spool.SpoolShape()`: drum 2.4 cm across and 3 cm long, its bottom 3 cm above the
      table, flanges 12.4 cm across, knob 4.5 cm from the axis) stands at x uniform in [`SPOOL_X_LOW`,
      `SPOOL_X_LOW` + `SPOOL_X_SPAN`], y uniform in [`SPOOL_Y_LOW`, `SPOOL_Y_LOW` + `SPOOL_Y_SPAN`];
    - the rope (`ROPE`: 60 cm, 30 capsules of 1.6 cm diameter) leaves the drum heading within +-`HEADING_SPREAD`
      (uniform) of -y, tangent to the drum on its counter-clockwise side; it runs level over the flange's rim,
      down to the table in two capsules and on over the table in a gentle S (`rope.wavy_turns`, amplitude
      uniform in [0, `ROPE_MAX_AMP`] rad, phase uniform).

    **Success:** the rope is coiled on the spool at least `min_turns` times (`spool.coil_turns`: the winding
    number about the spool's axis of the rope's polyline from its tied end up to where it first leaves the spool,
    beyond the flanges' rim or out from between them: rope wound below the bottom flange, over the top one or
    round the stand does not count) and it is let go (neither gripper touches the rope, `ee.touches`), so the
    coil holds by itself. The spool turns freely: how the rope gets there is the robot's choice.

    **Level 3:** (against Level 2's WrapRopeAroundPost: one gripper, 4 stages, one turn of rope carried round a
    fixed post, ~170 steps): two arms at once in 6 stages (grasp the crank knob; grasp the rope near its free end;
    lift it and carry it onto the drum's tangent line; turn the crank more than two full turns while the feeding
    hand follows the rope in along that line at the rate it winds on, closed loop; let go of the rope, then of
    the crank), ~300 steps. Two turns take ~45 cm of the 60 cm rope, which has to be laid in the 3 cm gap between
    the flanges, 3 cm above the table, turn on turn: a feeding hand that lags the take-up stalls the crank or
    pulls the rope out of its fingers, one that runs ahead drops slack under the flange. The spool turns freely,
    so the rope only winds while one hand turns the spool and the other keeps the rope in line (a tool used with
    both hands at once).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 7
    # the rope reaches ~55 cm from the spool towards -y, up to 20 cm to -x with its heading and S; the flanges
    # 6.2 cm round the axis
    TASK_REGION = (-0.36, 0.1, -0.5, 0.28)
    PARAMS = ("min_turns",)
    SPOOL = spool.SpoolShape()
    # 60 cm: the turns lie one round the other between the flanges (the first ~13 cm of rope, the second ~23 cm,
    # the solver's margin ~8 cm more), the feeding hand ends ~9 cm from the axis (clear of the crank hand) and
    # the rope needs ~10 cm to run over the flange and down to the table at reset
    ROPE = rope.RopeConfig(length=0.6, segments=30)
    SPOOL_X_LOW, SPOOL_X_SPAN = -0.15, 0.08  # the spool axis' x: uniform in [low, low + span]
    SPOOL_Y_LOW, SPOOL_Y_SPAN = 0.12, 0.06  # its y
    HEADING_SPREAD = np.deg2rad(15)  # the rope leaves the drum within this of -y
    ROPE_MAX_AMP = 0.12  # rad: largest amplitude of the rope's S on the table
    # the reward's `rope_grasped`: a gripper holds one of this many capsules at the free end (`ee.holds` costs ~9 ms a
    # capsule and side: about every capsule it was ~5x the physics step; at 4 capsules 0.13x PickCube-v1)
    FREE_END_CAPSULES = 2

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.spool = spool.build_spool(self.scene, "spool", self.SPOOL, self.ROPE)
        self.rope = self.spool.rope

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            at = torch.stack([self.SPOOL_X_LOW + torch.rand(b) * self.SPOOL_X_SPAN,
                              self.SPOOL_Y_LOW + torch.rand(b) * self.SPOOL_Y_SPAN], dim=1)
            heading = -np.pi / 2 + (torch.rand(b) * 2 - 1) * self.HEADING_SPREAD
            turns = rope.wavy_turns(b, self.spool.flat_joints + 1, self.ROPE_MAX_AMP)
            self.spool.lay(at, heading, turns)

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.ee.sides}
        obs.update(knob_grasped=info["knob_grasped"], rope_grasped=info["rope_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), knob_pos=self.spool.knob.pose.p,
                       spool_pos=self.spool.articulation.root.pose.p, spool_angle=self.spool.angle()[:, None],
                       turns=info["turns"][:, None])
        return obs

    def evaluate(self):
        turns = self.spool.turns()
        coiled = turns >= self.min_turns
        touched = self.ee.touches(self.rope.links)
        return {
            "success": coiled & ~touched,
            "turns": turns,
            "coiled": coiled,
            "touching_rope": touched,
            "knob_grasped": self.ee.holds(self.spool.knob),
            "rope_grasped": self.ee.holds(self.rope.links[-self.FREE_END_CAPSULES:]),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        """Reach the knob (1) and hold it (1), hold the rope (1), turns laid on the spool (3), coiled and let go
        (1); `max_dense_reward` on success."""
        reach = torch.stack([torch.linalg.norm(self.spool.knob.pose.p - self.ee.tcp(side).p, dim=1)
                             for side in self.ee.sides]).amin(dim=0)
        reward = torch.where(info["knob_grasped"], 2.0, 1 - torch.tanh(5 * reach))
        reward = reward + info["rope_grasped"].float() + 3 * (info["turns"] / self.min_turns).clamp(max=1)
        reward = reward + (info["coiled"] & ~info["touching_rope"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
