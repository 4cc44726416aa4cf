"""TossCatchCube (L3 rigid DG, family CatchBall): the left gripper tosses a cube, the right one catches it in the air."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg

from .base import CatchTask

# the right arm's ready pose: its hand palm up (fingers pointing up, closing along the world y axis), a cup with
# its TCP at about (-0.06, -0.33, 0.32), where the toss comes down; found offline with the arm's kinematics
# (palm up within 0.1 deg, every joint at least 0.35 rad from its limits, the wrist links >= 0.11 m above the table)
CATCHER_READY = (0.306, 0.95, -0.276, -1.957, -2.401, 0.336, -1.786)


@register_task("TossCatchCube")
class TossCatchCubeEnv(CatchTask):
    """**Task:** the left arm picks up a small cube lying on the left of the table and tosses it: it swings and
    opens its gripper at speed, so that the cube flies free through the air towards the right arm, whose
    gripper catches it in mid-air and holds it; the cube must not touch the table once picked.

    **Randomisation:**
    - the cube (side 2 x `cube_half`, ManiSkill's default density: 64 g) lies with its centre uniform in x in `cube_x_range`, y in
      `cube_y_range` (in front of the left arm) and its yaw uniform in `cube_yaw_range` (a cube: every yaw);
    - the robot's joints get the reset noise; the right arm starts in its ready pose, its hand palm up.

    **Success:** (the CatchBall family rule, `CatchTask`) the cube was tossed: after the left gripper had held it
    clear of the table (its centre higher than the cube's bounding radius plus a margin), it flew free for at least
    `min_flight_steps` consecutive control steps (at each, neither gripper touched it, `ee.touches`, and its
    velocity changed by gravity alone within `flight_tol`: no arm link or table pushed it either), the left
    gripper being the last to have held it, and its centre travelled at least `min_toss_distance` horizontally
    over that stretch (episode memory `tossed`); after the toss the left gripper never touched it again
    (`thrower_again`); it never touched the table after the left gripper first held it clear of the table
    (`touched_table`, checked at every physics step); and now the right gripper holds it (`ee.holds`), the left
    does not touch it, and its centre is at least `lift_height` above the table.

    **Level 3:** (a rung up from Level 2's two-gripper tasks and Level 1's HandoverCube, where the object is
    always held by one gripper or both): dynamics and timing. The cube leaves the left gripper at about
    1 m/s (near the top speed of the arms' TCP under `pd_ee_delta_pose`) and is out of reach of both grippers
    for about a quarter of a second (about five control steps, at least `min_flight_steps`), travelling
    about 20 cm through the air; the right gripper has to be where the parabola ends, within about a centimetre
    (the play of a 4 cm cube between fingers held 6.5 cm apart), aimed from the release state, and close in the
    control step after the cube comes in, before it bounces out. Stages: pick, toss, catch.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.1, -0.4, 0.4)
    PARAMS = CatchTask.PARAMS + ("cube_half", "cube_x_range", "cube_y_range", "cube_yaw_range")
    READY_JOINTS = {f"right_panda_joint{i}": angle for i, angle in enumerate(CATCHER_READY, 1)}

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cube = actors.build_cube(self.scene, half_size=self.cube_half, color=(0.95, 0.55, 0.1, 1), name="cube",
                                      initial_pose=Pose.create_from_pq([0, 0.2, self.cube_half]).sp)
        self.item = self.cube
        self.ITEM_RADIUS = float(np.sqrt(3) * self.cube_half) + 0.005

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.cube_x_range), uniform(b, self.cube_y_range),
                               torch.full((b,), self.cube_half)], dim=1)
            self.cube.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.cube_yaw_range))))

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["thrower_grasped"], right_grasped=info["catcher_grasped"],
                   tossed=info["tossed"])
        if "state" in self.obs_mode:
            obs.update(cube_pose=self.cube.pose.raw_pose, cube_vel=self.cube.linear_velocity,
                       left_tcp_to_cube=self.cube.pose.p - self.ee.tcp("left").p,
                       right_tcp_to_cube=self.cube.pose.p - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        cube = self.cube.pose.p
        left_reach = torch.linalg.norm(cube - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(cube - self.ee.tcp("right").p, dim=1)
        left, right = info["thrower_grasped"].float(), info["catcher_grasped"].float()
        height = (cube[:, 2] / self.lift_height).clamp(0, 1)
        flight = (info["airborne_steps"].float() / self.min_flight_steps).clamp(max=1)
        # stages: the left reaches, grasps and lifts; the cube flies free; the right gets under it and, once
        # it was tossed, holds it; a cube that touched the table after the pick, or that the left touched
        # again after the toss, earns nothing past the pick
        reward = (1 - torch.tanh(5 * left_reach)) + left + left * height
        reward = torch.where(info["picked"], reward.clamp(min=3) + flight, reward)
        reward = torch.where(info["tossed"], 4 + (1 - torch.tanh(5 * right_reach)) + 2 * right, reward)
        spoiled = info["touched_table"] | info["thrower_again"]
        reward = torch.where(spoiled, torch.minimum(reward, torch.full_like(reward, 3.0)), reward)
        reward[info["success"]] = self.max_dense_reward
        return reward
