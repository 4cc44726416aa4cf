"""WrapRopeAroundBoxHands (L3 deformable DX): two LEAP hands pass a rope hand over hand once around a box."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform, uniform_deg
from maniladder_ms.objects.tabletop import build_flat_box
from maniladder_ms.tasks.rope.base import RopeTask

BOX_HALF = (0.04, 0.05, 0.025)  # the box: 8 cm deep (x), 10 cm wide (y), 5 cm tall, fixed to the table
BOX_COLOR = (0.3, 0.45, 0.65, 1)
ANCHOR_HALF = (0.012, 0.012, 0.004)  # the visual clamp over the anchored capsule
U_JOINTS = 6  # the rope's U turn is spread over this many joints (30 degrees each: ~10 cm across)


@register_task("WrapRopeAroundBoxHands")
class WrapRopeAroundBoxHandsEnv(RopeTask, ManiLadderEnv):
    """**Task:** a box stands fixed on the table between the two arms; a rope lies beside it, one end tied
    down (its first capsule fixed, under a dark clamp) next to the box's near side, the rest running off to the
    right and doubling back. Wrap the rope once around the box with both hands: one hand carries the free end
    round one part of the way and lays it down, the other takes it there and carries it on round, over the
    tied-down part; then let go.

    **Randomisation:**
    - the box (8 cm deep, 10 cm wide, 5 cm tall, fixed to the table) stands at x uniform in `box_x_range`,
      y uniform in `box_y_range`, turned by a yaw uniform in +-`box_max_yaw`;
    - the rope (70 cm, 28 capsules of 1.6 cm diameter) is anchored at its first tip, which lies a gap uniform
      in `tip_gap_range` off the middle of the box's near (robot-side) face, shifted along that face by up
      to +-`tip_max_shift` (uniform); from there it lies flat towards the right (-y), its first capsule
      heading turned from the box's -y direction towards the robot by an angle uniform in `rope_yaw_range`
      (negative: away from it),
      in a gentle S (the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 28 + phase),
      amp uniform in [0, `rope_max_amp`], phase uniform), and from a fraction uniform in `u_at_range` of its
      joints on it turns back towards the box in a U (a half turn spread over `U_JOINTS` joints, ~10 cm
      across), so its free end lies ~2-25 cm right of the box.

    **Success:** the rope is wrapped around the box: its polyline (tied tip, capsule centres, free tip) winds at
    least `min_turns` times about the vertical axis through the box's centre (either sense,
    `rope.winding_number`); the wrap is around the box, not over it
    (every point of the rope below the box's top); both hands took part (episode memory `left_held` and
    `right_held`: at some step that hand held (`ee.holds`) one of the `end_capsules` capsules at the free
    end while one of them was at least `lift_height` off the table), so one hand dragging the rope round
    does not count; and the rope is let go (no hand touches it, `ee.touches`), so the wrap holds by itself.

    **Level 3:** (against Level 2's WrapRopeAroundPost: one gripper carries a 48 cm rope once round a post
    3 cm across on a circle 13 cm across, 4 stages, T ~ 26): the rope goes round a box 8 x 10 cm; the
    carrying hand's pinch keeps 5 cm off its faces (the two pinching LEAP fingers reach ~4 cm either side of
    the 1.6 cm rope), a path of ~67 cm a turn, and the free end has to go ~1.2 turns round from the pick; a
    hand that keeps its fingers along the rope turns its wrist with the path, ~430 degrees for the whole
    pass, more than Panda joint 7's 332-degree range, so the pass is hand over hand: 8 stages over both arms
    (the right hand pinches the rope's end between two fingers, carries it round the right and far faces and
    lays it down pointing away from the box; the left hand pinches it there, carries it on round the near
    face, over the tied-down part, lays it down; both let go and rise), ~400-500 control steps against ~170.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 7
    # the rope at reset (seeds 0-199): x -0.30 to 0.09, y -0.49 to 0.04 (up to ~45 cm right of the box)
    TASK_REGION = (-0.32, 0.1, -0.6, 0.1)
    PARAMS = ("min_turns", "end_capsules", "lift_height", "box_x_range", "box_y_range", "box_max_yaw",
              "tip_gap_range", "tip_max_shift", "rope_yaw_range", "u_at_range", "rope_max_amp")
    rope_anchored = True
    # 70 cm in 2.5 cm capsules: 1.1-1.2 turns round the box from the tie, the rope lying 1-20 cm off its faces; 28
    # capsules (under the 31 at which the rope's collision groups start to skip a far pair) keep the crossing over
    # the tied-down part a real contact
    rope_config = rope.RopeConfig(length=0.7, segments=28)

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the anchored rope (RopeTask)
        self.box = build_flat_box(self.scene, "box", BOX_HALF, BOX_COLOR, kinematic=True)
        builder = self.scene.create_actor_builder()
        if self.scene.can_render():
            builder.add_box_visual(half_size=list(ANCHOR_HALF),
                                   material=sapien.render.RenderMaterial(base_color=[0.15, 0.15, 0.18, 1]))
        builder.initial_pose = sapien.Pose(p=[0, 0.3, ANCHOR_HALF[2]])
        self.anchor = builder.build_kinematic(name="anchor")  # visual only: the rope's root is the anchor
        self.memory.flag("left_held")
        self.memory.flag("right_held")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            yaw = symmetric_deg(b, self.box_max_yaw)
            centre = torch.stack([uniform(b, self.box_x_range), uniform(b, self.box_y_range),
                                  torch.full((b,), BOX_HALF[2])], dim=1)
            self.box.set_pose(Pose.create_from_pq(centre, yaw_quat(yaw)))
            c, s = torch.cos(yaw), torch.sin(yaw)
            # the tie point in the box's frame: off its near (-x) face, shifted along it
            local = torch.stack([-(BOX_HALF[0] + uniform(b, self.tip_gap_range)),
                                 (torch.rand(b) * 2 - 1) * self.tip_max_shift], dim=1)
            tip = centre[:, :2] + torch.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]],
                                              dim=1)
            heading = yaw - np.pi / 2 - uniform_deg(b, self.rope_yaw_range)
            turns = rope.wavy_turns(b, self.rope_config.segments, np.deg2rad(self.rope_max_amp))
            # the U: a half turn towards the box spread over U_JOINTS joints, starting at a fraction of the rope
            first = (uniform(b, self.u_at_range) * (self.rope_config.segments - 1)).long()
            k = torch.arange(self.rope_config.segments - 1)[None]
            in_u = (k >= first[:, None]) & (k < first[:, None] + U_JOINTS)
            turns = turns + in_u * (np.pi / U_JOINTS)
            self.rope.lay_flat(tip, heading, turns, from_tip=True)
            first = self.rope.links[0].pose
            clamp_at = first.p.clone()
            clamp_at[:, 2] = 2 * self.rope_config.radius + ANCHOR_HALF[2]
            self.anchor.set_pose(Pose.create_from_pq(clamp_at, first.q))

    def box_frame(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The box's centre [B, 2] (top-down) and yaw [B]."""
        pose = self.box.pose
        w, z = pose.q[:, 0], pose.q[:, 3]
        return pose.p[:, :2], 2 * torch.atan2(z, w)

    def end_links(self) -> list:
        """The `end_capsules` capsules at the rope's free end."""
        return self.rope.links[-self.end_capsules:]

    def _update_memory(self):
        ends = torch.stack([link.pose.p[:, 2] for link in self.end_links()], dim=1)
        raised = ends.amax(dim=1) >= self.rope_config.radius + self.lift_height
        if not raised.any():
            return  # no contact query while the free end lies on the table
        for side in ("left", "right"):
            flag = f"{side}_held"
            if not self.memory[flag][raised].all():
                self.memory.latch(flag, raised & self.ee.holds(self.end_links(), side))

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in ("left", "right")}
        obs.update(left_held=info["left_held"], right_held=info["right_held"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), box_pose=self.box.pose.raw_pose,
                       turns=info["turns"])
        return obs

    def evaluate(self):
        points = self.rope.points()
        centre, _ = self.box_frame()
        turns, wound, below = rope.wound_around(points, centre, self.min_turns, 2 * BOX_HALF[2])
        touched = self.ee.touches(self.rope.links)
        both = self.memory["left_held"] & self.memory["right_held"]
        return {
            "success": wound & below & both & ~touched,
            "turns": turns,
            "wound": wound,
            "below_box_top": below,
            "left_held": self.memory["left_held"],
            "right_held": self.memory["right_held"],
            "touching_rope": touched,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        end = self.end_links()[0].pose.p
        reach = torch.maximum(*(1 - torch.tanh(5 * torch.linalg.norm(end - self.ee.tcp(side).p, dim=1))
                                for side in ("left", "right")))
        progress = (info["turns"].abs() / self.min_turns).clamp(max=1)
        reward = reach + info["left_held"].float() + info["right_held"].float() + 2 * progress
        reward = reward + (info["wound"] & ~info["touching_rope"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
