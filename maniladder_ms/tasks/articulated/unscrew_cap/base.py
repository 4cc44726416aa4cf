"""The UnscrewCap family's rule (OpenJarBimanual, UnscrewCapHand, OpenJarHands, TwistOpenBottleHands):
turn a screw lid or cap (`objects.jar`, its thread a revolute joint with friction) off its thread, the
container held by another end effector (or clamped to the table).

The family base `UnscrewCapTask` holds the rule, `evaluate` and the reward once for every embodiment; the
task classes set the container's shape, whether it is clamped and its placement; their solvers are in
`solvers/articulated/unscrew_cap/`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.jar import JarShape, build_screw_jar, screw_angle


class UnscrewCapTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the lid is off its thread: its thread joint has turned
    by at least `release_angle` (counter-clockwise from above, the unscrewing direction) from where it
    was screwed home, and the turn was made by a hand on the lid while the container was held: the
    episode memory `held_turn` sums the joint's change over the control steps in which an end effector
    held the lid (`ee.holds`) while another end effector held the container's body (for a container
    clamped to the table, `CLAMPED`: while an end effector held the lid), at the step's start or end;
    turning back counts against it, and turns made otherwise (a lid dragged back by a releasing hand, a
    spin of the whole container) do not count. Success: `held_turn` and the joint's angle both reach
    `release_angle`. The thread's friction (`thread_torque`, the joint's force-limited drive) keeps the
    lid still unless it is twisted harder, so a container that no other end effector holds turns with
    the lid instead.
    """

    # release_angle: degrees of unscrewing that free the lid from its thread; thread_torque: N m of the
    # thread's dry friction; the container's layout at reset: its centre uniform in x in jar_x_range, y in
    # jar_y_range, its yaw (where the lid's stripes point) in jar_yaw_range (deg)
    PARAMS = ("release_angle", "thread_torque", "jar_x_range", "jar_y_range", "jar_yaw_range")
    jar_shape = JarShape()
    CLAMPED = False  # the container's body is fixed to the table (no end effector needs to hold it)
    body_color, lid_color = (0.78, 0.86, 0.9, 1), (0.8, 0.2, 0.15, 1)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.jar = build_screw_jar(self.scene, "jar", self.jar_shape, self.thread_torque, self.body_color,
                                   self.lid_color, fixed=self.CLAMPED)
        self.body = self.jar.links_map["jar_body"]
        self.lid = self.jar.links_map["jar_lid"]
        self.memory.value("last_angle")  # the lid's thread angle after the last step
        self.memory.value("last_held")  # 1 where the lid was held (and the body, unless clamped) after the last step
        self.memory.value("held_turn")  # rad unscrewed in steps the lid (and the body) was held

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.jar_x_range), uniform(b, self.jar_y_range), torch.zeros(b)], dim=1)
            self.jar.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.jar_yaw_range))))
            self.jar.set_qpos(torch.zeros(b, 1))
            self.jar.set_qvel(torch.zeros(b, 1))
            self.memory.store("last_angle", torch.zeros(b, 1), env_idx)

    def lid_top(self) -> torch.Tensor:
        """(num_envs, 3) world centre of the lid's top face."""
        up = torch.tensor([[0.0, 0.0, self.jar_shape.height]], device=self.device)
        return (self.jar.pose * Pose.create_from_pq(up)).p

    def _grips(self) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
        """Per side, (lid held, body held) as (num_envs,) bools (`ee.holds`, whose answers the memory update
        and `evaluate` of one control step share; a clamped body is never asked)."""
        out = {}
        for side in self.ee.sides:
            lid = self.ee.holds(self.lid, side)
            out[side] = (lid, torch.zeros_like(lid) if self.CLAMPED else self.ee.holds(self.body, side))
        return out

    def _twisting(self, grips: dict) -> torch.Tensor:
        """(num_envs,) an end effector holds the lid while another holds the body (clamped: one holds the lid)."""
        if self.CLAMPED:
            return torch.stack([lid for lid, _ in grips.values()]).any(dim=0)
        out = None
        for a in grips:
            for b in grips:
                if a != b:
                    both = grips[a][0] & grips[b][1]
                    out = both if out is None else out | both
        return out

    def _update_memory(self):
        super()._update_memory()
        angle = screw_angle(self.jar)
        held = self._twisting(self._grips())
        counted = held | (self.memory["last_held"][:, 0] > 0.5)
        delta = angle - self.memory["last_angle"][:, 0]
        self.memory.store("held_turn", self.memory["held_turn"] + torch.where(counted, delta, 0.0)[:, None])
        self.memory.store("last_angle", angle[:, None])
        self.memory.store("last_held", held.float()[:, None])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.ee.sides}
        obs.update(lid_angle=info["lid_angle"], held_turn=info["held_turn"])
        if "state" in self.obs_mode:
            obs.update(jar_pose=self.jar.pose.raw_pose, lid_top=self.lid_top())
        return obs

    def evaluate(self):
        grips = self._grips()
        angle = screw_angle(self.jar)
        held_turn = self.memory["held_turn"][:, 0]
        release = np.deg2rad(self.release_angle)
        return {
            "success": (held_turn >= release) & (angle >= release),
            "lid_angle": angle,
            "held_turn": held_turn,
            "lid_held": torch.stack([lid for lid, _ in grips.values()]).any(dim=0),
            "body_held": torch.stack([body for _, body in grips.values()]).any(dim=0),
            "twisting": self._twisting(grips),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        lid = self.lid_top()
        reach = torch.stack([torch.linalg.norm(lid - self.ee.tcp(s).p, dim=1) for s in self.ee.sides]).min(dim=0).values
        reward = (1 - torch.tanh(5 * reach)) + info["lid_held"].float()
        if not self.CLAMPED:
            reward = reward + info["body_held"].float()
        progress = (info["held_turn"] / np.deg2rad(self.release_angle)).clamp(0, 1)
        reward = reward + 3 * progress
        reward[info["success"]] = self.max_dense_reward
        return reward
