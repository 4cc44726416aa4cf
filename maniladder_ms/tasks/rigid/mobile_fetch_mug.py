"""MobileFetchMug (L2 rigid SG, mobile): fetch a mug from a side table with the TidyBot and set it down in a zone."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.envs.scene import TABLE_HALF_SIZE
from maniladder_ms.geometry import tilt, yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.objects.mug import MUG_DENSITY, MugShape, build_mug


@register_task("MobileFetchMug")
class MobileFetchMugEnv(ManiLadderEnv):
    """**Task:** a mug stands on a side table to the left of the main table, out of the arm's reach. Drive the
    holonomic base along the main table to the side table, pick the mug, drive back and set it down upright
    in the target zone (a square tile) on the main table, and let go.

    **Randomisation:** the side table (50 x 50 cm, its top level with the main table's, its near edge in
    line with the main table's) stands with its centre at x = `SIDE_TABLE_X` = -0.5, y uniform in
    `side_table_y_range` (18-22 cm of floor between the tables); the mug (7.4 cm wide, 9 cm tall, loop handle,
    ~0.2 kg) stands upright on it at x uniform in `mug_x_range`, y within +-`mug_max_dy` of the side table's
    centre, its yaw uniform in `mug_yaw_range` (the handle on the mug's -x side at yaw 0); the zone's centre is
    uniform in x in `zone_x_range`, y within +-`zone_max_y` on the main table. The robot starts at its rest pose
    (arm joints with the usual noise), the base at y = 0.

    Out of reach from the start: the arm's shoulder (Panda joint 2) stands at (-0.955, 0, 0.003); the TCP
    comes at most 0.95 m from it (the farthest of 6000 random arm postures within the joint limits, refined
    by a local search: 0.947 m; the Panda's rated reach is 0.855 m to the flange), while every point of the
    mug (its handle included, 8 cm from its axis) lies at least 1.10 m from it (the mug's axis at least
    1.18 m away: x >= -0.515, y >= 1.105). The base must drive about a metre and back.

    **Success:** the mug was fetched: at some control step the gripper held it (`ee.holds`) with its bottom
    at least `lift_height` above the table top (episode memory `fetched`); and now the mug's centre lies
    within `zone_half` of the zone's centre in x and in y, its bottom rests on the main table (within
    `rest_tol` of the top), it stands upright (tilted by less than `max_tilt`), and the gripper does not
    hold it.

    **Level 2:** against Level 1's SG tasks (one fixed arm, one pick and place on one table, e.g. HangMug:
    3 stages, ~105 steps in its samples, horizon 150), the base must drive: ~1 m to the side table and ~1 m
    back at up to 0.5 m/s, the arm's TCP riding with it, between a pick and a place at two places no single
    arm pose reaches; 4 stages (drive to the side table, grasp and lift, drive back with the mug hanging
    from a rim grasp, set it down within 4 cm and upright within 10 degrees and release), 248 steps mean
    (233-258, 20 demos) within a horizon of 600.
    """

    SUPPORTED_ROBOTS = ["ml_tidybot"]
    max_dense_reward = 10
    TASK_REGION = (-0.55, -0.33, -0.2, 0.2)
    PARAMS = ("zone_half", "lift_height", "rest_tol", "max_tilt",
              "side_table_y_range", "mug_x_range", "mug_max_dy", "mug_yaw_range", "zone_x_range", "zone_max_y")
    mug_shape = MugShape()
    SIDE_TABLE_HALF = (0.25, 0.25)  # x, y half extents of the side table's top (its top is level with the main table's)
    SIDE_TABLE_X = -0.5  # its near edge in line with the main table's (x = -0.75), which the base drives along
    # the cameras look over both tables (the side table lies 0.88-1.42 m to the left of the robot's axis)
    CAMERA_VIEWS = {
        "front_camera": ([0.65, 0.3, 0.85], [-0.75, 0.55, -0.1]),
        "left_camera": ([0.1, 1.55, 0.6], [-0.55, 0.5, 0.0]),
        "top_camera": ([-0.5, 0.55, 1.6], [-0.45, 0.55, 0.0]),
    }
    RENDER_VIEW = ([0.7, -0.5, 1.0], [-0.55, 0.6, 0.0])
    # a gripper whose TCP is further than this from the mug's bottom centre cannot hold it (the rim lies
    # within 10 cm of it): the rule asks for the hold (a contact query) only nearer
    HOLD_REACH = 0.15

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        hx, hy = self.SIDE_TABLE_HALF
        hz = TABLE_HALF_SIZE[2]
        builder = self.scene.create_actor_builder()
        builder.add_box_collision(half_size=[hx, hy, hz])
        if self.scene.can_render():
            mat = sapien.render.RenderMaterial(base_color=[0.45, 0.5, 0.55, 1], roughness=0.7, metallic=0.0)
            builder.add_box_visual(half_size=[hx, hy, hz], material=mat)
        builder.initial_pose = sapien.Pose(p=[self.SIDE_TABLE_X, float(np.mean(self.side_table_y_range)), -hz])
        self.side_table = builder.build_kinematic(name="side_table")
        self.mug = build_mug(self.scene, "mug", self.mug_shape, color=(0.9, 0.85, 0.7, 1), friction=1.0,
                             density=MUG_DENSITY)
        self.zone = build_zone_marker(self.scene, "zone", self.zone_half, color=(0.2, 0.7, 0.3, 1))
        self.memory.flag("fetched")  # held with its bottom lift_height above the table top

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            side_y = uniform(b, self.side_table_y_range)
            hz = TABLE_HALF_SIZE[2]
            self.side_table.set_pose(Pose.create_from_pq(
                torch.stack([torch.full((b,), self.SIDE_TABLE_X), side_y, torch.full((b,), -hz)], dim=1)))
            mug = torch.stack([uniform(b, self.mug_x_range), side_y + (torch.rand(b) * 2 - 1) * self.mug_max_dy,
                               torch.zeros(b)], dim=1)
            self.mug.set_pose(Pose.create_from_pq(mug, yaw_quat(uniform_deg(b, self.mug_yaw_range))))
            zone = torch.stack([uniform(b, self.zone_x_range), (torch.rand(b) * 2 - 1) * self.zone_max_y,
                                torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.zone.set_pose(Pose.create_from_pq(zone))

    def holds_mug(self) -> torch.Tensor:
        near = torch.linalg.norm(self.ee.tcp().p - self.mug.pose.p, dim=1) <= self.HOLD_REACH
        if not bool(near.any()):
            return near
        return self.ee.holds(self.mug) & near

    def _update_memory(self):
        up = (self.mug.pose.p[:, 2] >= self.lift_height) & ~self.memory["fetched"]
        if bool(up.any()):
            self.memory.latch("fetched", up & self.holds_mug())

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"], fetched=info["fetched"],
                   zone_pos=self.zone.pose.p)
        if "state" in self.obs_mode:
            obs.update(mug_pose=self.mug.pose.raw_pose, side_table_pos=self.side_table.pose.p,
                       tcp_to_mug=self.mug.pose.p - self.ee.tcp().p, mug_to_zone=self.zone.pose.p - self.mug.pose.p)
        return obs

    def evaluate(self):
        offset = self.mug.pose.p - self.zone.pose.p
        is_grasped = self.holds_mug()
        mug_tilt = tilt(self.mug)
        in_zone = offset[:, :2].abs().max(dim=1).values <= self.zone_half
        on_table = self.mug.pose.p[:, 2].abs() <= self.rest_tol
        is_upright = mug_tilt < np.deg2rad(self.max_tilt)
        fetched = self.memory["fetched"]
        return dict(success=fetched & in_zone & on_table & is_upright & ~is_grasped, fetched=fetched,
                    is_grasped=is_grasped, in_zone=in_zone, on_table=on_table, is_upright=is_upright,
                    tilt=mug_tilt, zone_dist=offset[:, :2].norm(dim=1))

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the mug (the base has to drive there), hold it, lift it; carry it over the zone, set it down
        # upright, let go
        reach = torch.linalg.norm(self.mug.pose.p - self.ee.tcp().p, dim=1)
        reward = 2 * (1 - torch.tanh(2 * reach)) + info["is_grasped"]
        fetched = info["fetched"].float()
        reward += fetched * (1 + 3 * (1 - torch.tanh(2 * info["zone_dist"])))
        placed = info["in_zone"] & info["on_table"] & info["is_upright"]
        reward += fetched * placed * (1 + (~info["is_grasped"]).float())
        reward[info["success"]] = self.max_dense_reward
        return reward
