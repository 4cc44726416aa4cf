"""RopeIntoGroove (L2 deformable DG): both arms lift a rope by its ends and lay it into a U-shaped groove."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import Channel
from maniladder_ms.tasks.rope.base import RopeBetweenArmsTask

GROOVE_LENGTH = 0.46  # the rope's 40 cm and 3 cm to spare at each end
GROOVE_WALL = 0.015  # thickness of each wall
GROOVE_FLOOR = 0.004  # the plate the walls stand on: the groove's floor lies this high
GROOVE_COLOR, GROOVE_FLOOR_COLOR = (0.55, 0.45, 0.35, 1), (0.3, 0.25, 0.2, 1)


@register_task("RopeIntoGroove")
class RopeIntoGrooveEnv(RopeBetweenArmsTask, ManiLadderEnv):
    """**Task:** a rope lies across the table between the two arms, and beyond it (away from the robot) a
    straight U-shaped groove is fixed to the table, running the same way; each gripper takes one end of the rope,
    together they lift it, carry it over the groove, lower it in and let go: the rope lies in the groove.

    **Randomisation:**
    - the rope as in LiftRopeBimanual (`RopeBetweenArmsTask`; `rope.RopeConfig()`: 40 cm, 20 capsules of
      1.6 cm diameter): flat across the table (along y) in a gentle S (the in-plane turn between capsules k and
      k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp uniform in [0, `rope_max_amp`], phase uniform), the mean
      of its capsule centres at x uniform in `rope_x_range`, y uniform in `rope_y_range`, its first capsule
      heading within +-`rope_max_yaw` (uniform) of +y or of -y;
    - the groove (46 cm long, open at both ends: a 4 mm plate and two 1.5 cm thick walls, `groove_width` apart
      and `groove_depth` high above the plate) has its axis within +-`groove_max_yaw` (uniform) of the y axis and
      its centre at y uniform in `groove_y_range`; along x it lies beyond the rope: at the y of every capsule, the
      groove's outer face of the near wall is at least a gap uniform in `groove_gap_range` (one per episode) further
      along +x than that capsule's far side (so the groove's centre lands at x in [-0.07, 0.13] in 98% of
      episodes, 8-23 cm from the rope's middle; the extremes over 200k draws: x up to 0.21, 5-28 cm).

    **Success:** at least `min_fraction` of the rope's capsules are inside the groove (`metrics.
    inside_channel_fraction`: the capsule's centre between the walls, at most half of `groove_width` from the
    groove's axis sideways, between the groove's ends, and below the walls' top, `groove_depth` above its floor);
    the rope is let go (no gripper touches it, `ee.touches`); and earlier in the episode both grippers held it at
    the same time, each (`ee.holds`) one of the `end_capsules` outermost capsules at the end on its side (episode
    memory `both_held`: a lay by both arms, not a drag by one end).

    **Level 2:** (against Level 1's LiftRopeBimanual, same rope and layout: 2 stages, grasp both ends and lift them
    15 cm with 80% spread, no placement tolerance, ~80 steps): 5 stages (grasp both ends at once; lift; carry the
    rope 8-23 cm across the table and turn it up to 35 degrees onto the groove's axis; lower it in; release; ~125
    steps), the two arms in lock-step all the way (a rope carried by one end drags along its own length, never
    sideways into a groove, and each gripper has to turn its capsule the short way onto the axis: turned the long
    way round the capsule lags in the fingers and the rope lands across a wall); the groove is 22 mm wide for a 16
    mm rope, 3 mm to spare on each side at every one of the 20 capsules, while the fingers closed on the rope (46 mm
    across: each fingertip is 15 mm thick) cannot enter it, so the rope is let go above the walls' 19 mm top and has
    to drop in straight; 17 of 20 capsules must end inside (a capsule resting on a wall top counts out), and the
    groove lies 3-6 cm beyond the rope, so the approach opens the grippers only half way (3 cm) to keep the fingers
    off its wall.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 8
    # x up to 0.31: the groove's far corner reaches x = 0.305 at the extremes of its draw (numpy, 200k draws)
    TASK_REGION = (-0.3, 0.31, -0.32, 0.32)
    PARAMS = ("min_fraction", "groove_width", "groove_depth", "end_capsules", "groove_max_yaw", "groove_y_range",
              "groove_gap_range") + RopeBetweenArmsTask.ROPE_LAYOUT_PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the rope (RopeBetweenArmsTask)
        self.groove = Channel(self.scene, "groove", self.groove_width, self.groove_depth, GROOVE_LENGTH, GROOVE_WALL,
                              GROOVE_FLOOR, GROOVE_COLOR, GROOVE_FLOOR_COLOR)
        self.memory.flag("both_held")  # both grippers held the rope's ends at the same time

    def place_by_rope(self, centres: torch.Tensor):
        """The groove beyond the rope just laid (`RopeBetweenArmsTask`), its `centres` [b, segments, 3]."""
        b = len(centres)
        axis = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.groove_max_yaw)
        y = uniform(b, self.groove_y_range)
        # the groove's centre line (x at each capsule's y) lies beyond every capsule by the capsule's radius, the
        # groove's half width (inner half width and a wall) and the gap, all measured along x
        gap = uniform(b, self.groove_gap_range)
        slope = torch.cos(axis) / torch.sin(axis)  # x per y along the groove's axis
        farthest = (centres[..., 0] - (centres[..., 1] - y[:, None]) * slope[:, None]).amax(dim=1)
        x = farthest + self.rope_config.radius + (self.groove_width / 2 + GROOVE_WALL) / torch.sin(axis) + gap
        self.groove.set_pose(Pose.create_from_pq(torch.stack([x, y, torch.zeros(b)], dim=1), yaw_quat(axis)))

    def end_points(self) -> dict[str, torch.Tensor]:
        """Centres of the second capsule from each end (where the solver grasps), keyed by side, [B, 3]."""
        return self.side_points(1)

    def _update_memory(self):
        if bool(self.memory["both_held"].all()):  # latched in every sub-scene: no contact query needed
            return
        held = self.end_holds()
        self.memory.latch("both_held", held["left"] & held["right"])

    def _get_obs_extra(self, info: dict):
        obs = super()._get_obs_extra(info)
        if "state" in self.obs_mode:
            obs.update(groove_pose=self.groove.pose.raw_pose, inside_fraction=info["inside_fraction"])
        return obs

    def evaluate(self):
        centres = self.rope.points()[:, 1:-1]
        fraction = self.groove.inside_fraction(centres)
        # mean distance of the rope's capsules from the groove's axis line (top-down), for the reward
        off_axis = self.groove.off_axis(centres).mean(dim=1)
        in_groove = fraction >= self.min_fraction
        touched = self.ee.touches(self.rope.links)
        grasped = self.end_holds()
        both_held = self.memory["both_held"]
        return {
            "success": in_groove & ~touched & both_held,
            "inside_fraction": fraction,
            "in_groove": in_groove,
            "off_axis": off_axis,
            "touching_rope": touched,
            "both_held": both_held,
            "left_grasped": grasped["left"],
            "right_grasped": grasped["right"],
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        near_axis = 1 - torch.tanh(10 * info["off_axis"])
        before = self._two_arm_reward(info, near_axis)  # reach and grasp both ends (4), then move over the groove
        after = 4 + near_axis + 2 * info["inside_fraction"] + (info["in_groove"] & ~info["touching_rope"]).float()
        reward = torch.where(info["both_held"], torch.maximum(before, after), before)
        reward[info["success"]] = self.max_dense_reward
        return reward
