"""WrapRopeAroundPost (L2 deformable SG): carry a rope's free end once around a post, lay it down, let go."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import build_upright_cylinder
from maniladder_ms.tasks.rope.base import RopeTask

POST_COLOR = (0.35, 0.35, 0.4, 1)
ANCHOR_HALF = (0.012, 0.012, 0.004)  # the visual clamp over the anchored capsule


@register_task("WrapRopeAroundPost")
class WrapRopeAroundPostEnv(RopeTask, ManiLadderEnv):
    """**Task:** a rope lies on the table, one end tied down (its first capsule fixed, under a dark clamp)
    beside a short vertical post; grasp the rope's free end, carry it once around the post low over the
    table, lay it down and let go: the rope stays wrapped around the post.

    **Randomisation:**
    - the post (radius `post_radius`, height `post_height`, fixed to the table) stands at x uniform in
      `post_x_range`, y uniform in `post_y_range`;
    - the rope (48 cm, 24 capsules of 1.6 cm diameter) is anchored at its first tip,
      which lies at a distance uniform in `tip_distance_range` from the post axis, on a random side (+y or -y)
      at a bearing within +-`tip_max_bearing` (uniform) of that side; from there it lies flat towards the robot
      and outwards, its first capsule heading uniform in `rope_yaw_range` measured from that side towards -x
      (the free end 0.45-0.6 m from the arm's base), in a gentle S (the in-plane turn
      between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 24 + phase), amp uniform in
      [0, `rope_max_amp`], phase uniform).

    **Success:** the rope winds about the post's axis at least `min_turns` times (the winding number of
    the rope's polyline, anchored tip to free tip, about the vertical axis through the post centre, either
    sense: `rope.winding_number`); the wrap is around the post, not over it (every point of the rope
    below the post's top, `post_height`); and the rope is let go (the gripper does not touch it,
    `ee.touches`), so the wrap holds by itself.

    **Level 2:** (against Level 1's DragRopeToGoal: 2 stages, grasp and one straight drag, 40 cm of rope
    into a 22 cm zone): 4 stages (grasp the free end; carry it round a post of 3 cm diameter until the
    rope winds 1.2 turns, most of a full circle of the hand; lay it down; release); the TCP circles 6.5 cm from the post
    axis at a fixed 3 cm height, between the rope lying on the table (its top 1.6 cm up) and the post's
    5 cm top (the hand's body clears it by 1.7 cm, the closed fingers' outer ends pass 1.6 cm from its
    side), and the rope has to cross over its own standing part to close the turn; the winding is measured
    on the whole rope after release, so a carry that slips or rides over the post fails.
    """

    max_dense_reward = 5
    TASK_REGION = (-0.45, 0.2, -0.56, 0.56)
    PARAMS = ("post_radius", "post_height", "min_turns", "post_x_range", "post_y_range", "tip_distance_range",
              "tip_max_bearing", "rope_yaw_range", "rope_max_amp")
    rope_anchored = True
    # 48 cm (the default 40 cm in 2 cm capsules, 4 capsules longer): the standing part, one turn round the
    # post and the carried end need ~40 cm, and friction round the post (capstan) stops the rope sliding
    # on once wound; at 40 cm the carried end was pulled out of the fingers short of the turn
    rope_config = rope.RopeConfig(length=0.48, segments=24)

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the anchored rope (RopeTask)
        self.post = build_upright_cylinder(self.scene, "post", self.post_radius, self.post_height / 2, 800,
                                           POST_COLOR, kinematic=True)
        builder = self.scene.create_actor_builder()
        if self.scene.can_render():
            builder.add_box_visual(half_size=list(ANCHOR_HALF),
                                   material=sapien.render.RenderMaterial(base_color=[0.15, 0.15, 0.18, 1]))
        builder.initial_pose = sapien.Pose(p=[0, 0.3, ANCHOR_HALF[2]])
        self.anchor = builder.build_kinematic(name="anchor")  # visual only: the rope's root is the anchor

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            post = torch.stack([uniform(b, self.post_x_range), uniform(b, self.post_y_range),
                                torch.full((b,), self.post_height / 2)], dim=1)
            self.post.set_pose(Pose.create_from_pq(post))
            side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0)
            bearing = side * (np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.tip_max_bearing))
            distance = uniform(b, self.tip_distance_range)
            tip = post[:, :2] + distance[:, None] * torch.stack([torch.cos(bearing), torch.sin(bearing)], dim=1)
            low, high = self.rope_yaw_range
            heading = side * (np.pi / 2 + np.deg2rad(low) + torch.rand(b) * np.deg2rad(high - low))
            turns = rope.wavy_turns(b, self.rope_config.segments, np.deg2rad(self.rope_max_amp))
            self.rope.lay_flat(tip, heading, turns, from_tip=True)
            first = self.rope.links[0].pose
            clamp_at = first.p.clone()
            clamp_at[:, 2] = 2 * self.rope_config.radius + ANCHOR_HALF[2]
            self.anchor.set_pose(Pose.create_from_pq(clamp_at, first.q))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), post_pos=self.post.pose.p,
                       turns=info["turns"])
        return obs

    def evaluate(self):
        points = self.rope.points()
        turns, wound, below = rope.wound_around(points, self.post.pose.p[:, :2], self.min_turns, self.post_height)
        touched = self.ee.touches(self.rope.links)
        return {
            "success": wound & below & ~touched,
            "turns": turns,
            "wound": wound,
            "below_post_top": below,
            "touching_rope": touched,
            "is_grasped": self.ee.holds(self.rope.links[-3:]),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        end = self.rope.links[-2].pose.p
        reward = 1 - torch.tanh(5 * torch.linalg.norm(end - self.ee.tcp().p, dim=1))
        progress = (info["turns"].abs() / self.min_turns).clamp(max=1)
        reward = torch.where(info["wound"], 2.0, reward + info["is_grasped"].float())
        reward = reward + 2 * progress + (info["wound"] & ~info["touching_rope"]).float() * 0.5
        reward[info["success"]] = self.max_dense_reward
        return reward
