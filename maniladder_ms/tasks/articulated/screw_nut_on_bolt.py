"""ScrewNutOnBolt (L3 rigid DG, family ScrewNutOnBolt): one arm lifts a bolt and holds it upright, the other screws
the nut started on its end down its thread."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.bolt import BoltShape, build_bolt_and_nut, nut_advance, nut_angle, thread_targets


@register_task("ScrewNutOnBolt")
class ScrewNutOnBoltEnv(ManiLadderEnv):
    """**Task:** a bolt stands on its hex head on the table, a hex nut started on the upper end of its shaft.
    One gripper takes the bolt's shaft from the side, lifts the bolt off the table and holds it upright in
    the air; the other grips the nut from above across its flats and screws it on, clockwise seen from above,
    in strokes (twist, let go, turn the open hand back, grip again), following it down the shaft.

    **Randomisation:** the bolt (`objects.bolt`, `BOLT`: a 16 mm nylon shaft 14 cm long on a hex head 3 cm
    across its flats; the nut 28 mm across its flats, 14 mm tall, its top flush with the shaft's end) has its
    axis uniform in x in `bolt_x_range`, y in `bolt_y_range`, its yaw (where the head's and the nut's flats
    face) uniform in `bolt_yaw_range` (the hex repeats every sixth of a turn).

    **Success:** the nut has run at least `min_advance` down the shaft (its carriage joint), and so has the
    episode memory `held_advance`, which adds up the nut's advance (`thread_pitch` per turn of the thread
    joint) only over control steps in which one gripper held the bolt (`ee.holds`) and the other the nut,
    with the bolt's base (the head's bottom face, on its axis) at least `lift_height` above the table, at the
    step's start or end; turning back counts against it. The thread resists with `thread_torque` of dry
    friction: a bolt that no gripper holds turns with the nut (and the nut then does not advance on it), and a
    turn made while the bolt stands on the table, or with one of the grips let go, does not count.

    **Level 3:** (against Level 2's OpenJarBimanual: a 6 cm jar held standing on the table while its round
    6.6 cm lid is turned 540 degrees in two strokes) the holding gripper must lift the bolt off the table by a
    16 mm shaft and hold it upright in the air for the whole turn (a turn while the bolt stands on the table
    does not count), so its grip alone carries the bolt and the thread's torque on an 8 mm lever (the jar's
    body, 30 mm, stood on the table, whose friction shared the load); the twisting gripper must close across
    the flats of a 28 mm hex nut (under half the lid's width; the lid was round, any yaw gripped it), each
    regrasp at a yaw a multiple of sixty degrees from the nut's as it now stands, and its grip follows the nut
    down the shaft as it advances (the lid did not move along its axis); seven stages (take the bolt's shaft,
    lift it, grip the nut, twist, let go and turn back, grip again, twist), ~480 control steps against the
    jar's ~465, with about 450 degrees of turn (`min_advance` at `thread_pitch`).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    # min_advance: m the nut must run down the shaft; thread_pitch: m of advance per turn; thread_torque: N m of
    # the thread's dry friction; lift_height: m the bolt's base must be above the table while the nut is turned;
    # the bolt's layout at reset: its axis uniform in x in bolt_x_range, y in bolt_y_range, yaw in bolt_yaw_range
    PARAMS = ("min_advance", "thread_pitch", "thread_torque", "lift_height", "bolt_x_range", "bolt_y_range",
              "bolt_yaw_range")
    BOLT = BoltShape()
    max_dense_reward = 7
    TASK_REGION = (-0.22, 0.06, -0.15, 0.25)
    bolt_color, nut_color = (0.62, 0.64, 0.68, 1), (0.85, 0.6, 0.1, 1)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.fastener = build_bolt_and_nut(self.scene, "fastener", self.BOLT, self.thread_torque, self.bolt_color,
                                           self.nut_color)
        self.bolt = self.fastener.links_map["fastener_bolt"]
        self.nut = self.fastener.links_map["fastener_nut"]
        self.memory.value("last_angle")  # the nut's thread angle after the last step
        self.memory.value("last_held")  # 1 where the bolt and the nut were held, the bolt raised, after the last step
        self.memory.value("held_advance")  # m the nut advanced in steps both were held with the bolt raised

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.bolt_x_range), uniform(b, self.bolt_y_range), torch.zeros(b)], dim=1)
            self.fastener.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.bolt_yaw_range))))
            self.fastener.set_qpos(torch.zeros(b, 2))
            self.fastener.set_qvel(torch.zeros(b, 2))
            thread_targets(self.fastener, self.thread_pitch)
            self.memory.store("last_angle", torch.zeros(b, 1), env_idx)

    def _before_simulation_step(self):
        super()._before_simulation_step()
        thread_targets(self.fastener, self.thread_pitch)  # the thread's lead: the advance follows the turn

    def nut_top(self) -> torch.Tensor:
        """(num_envs, 3) world centre of the nut's top face."""
        up = torch.tensor([[0.0, 0.0, self.BOLT.nut_height]], device=self.device)
        return (self.nut.pose * Pose.create_from_pq(up)).p

    def bolt_raised(self) -> torch.Tensor:
        """(num_envs,) the bolt's base (the head's bottom face, on its axis) is at least `lift_height` up."""
        return self.bolt.pose.p[:, 2] >= self.lift_height

    def _grips(self) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
        """Per side, (bolt held, nut held) as (num_envs,) bools (`ee.holds`)."""
        return {side: (self.ee.holds(self.bolt, side), self.ee.holds(self.nut, side)) for side in self.ee.sides}

    def _screwing(self, grips: dict) -> torch.Tensor:
        """(num_envs,) one gripper holds the bolt, the other the nut, and the bolt is raised."""
        a, b = self.ee.sides
        both = (grips[a][0] & grips[b][1]) | (grips[b][0] & grips[a][1])
        return both & self.bolt_raised()

    def _update_memory(self):
        super()._update_memory()
        angle = nut_angle(self.fastener)
        held = self._screwing(self._grips())
        counted = held | (self.memory["last_held"][:, 0] > 0.5)
        delta = (angle - self.memory["last_angle"][:, 0]) * (self.thread_pitch / (2 * np.pi))
        self.memory.store("held_advance", self.memory["held_advance"] + torch.where(counted, delta, 0.0)[:, None])
        self.memory.store("last_angle", angle[:, None])
        self.memory.store("last_held", held.float()[:, None])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.ee.sides}
        obs.update(nut_advance=info["nut_advance"], held_advance=info["held_advance"])
        if "state" in self.obs_mode:
            obs.update(bolt_pose=self.bolt.pose.raw_pose, nut_pose=self.nut.pose.raw_pose)
        return obs

    def evaluate(self):
        grips = self._grips()
        advance = nut_advance(self.fastener)
        held_advance = self.memory["held_advance"][:, 0]
        return {
            "success": (held_advance >= self.min_advance) & (advance >= self.min_advance),
            "nut_advance": advance,
            "held_advance": held_advance,
            "bolt_held": torch.stack([bolt for bolt, _ in grips.values()]).any(dim=0),
            "nut_held": torch.stack([nut for _, nut in grips.values()]).any(dim=0),
            "bolt_raised": self.bolt_raised(),
            "screwing": self._screwing(grips),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        shaft = self.bolt.pose.p + torch.tensor([[0.0, 0.0, self.BOLT.head_height + self.BOLT.shaft_length / 2]],
                                                device=self.device)
        reach_bolt = torch.linalg.norm(shaft - self.ee.tcp(self.ee.sides[0]).p, dim=1)
        reach_nut = torch.linalg.norm(self.nut_top() - self.ee.tcp(self.ee.sides[1]).p, dim=1)
        reward = (1 - torch.tanh(5 * reach_bolt)) + (1 - torch.tanh(5 * reach_nut))
        reward = reward + info["bolt_held"].float() + (info["bolt_held"] & info["bolt_raised"]).float()
        reward = reward + info["nut_held"].float()
        progress = (info["held_advance"] / self.min_advance).clamp(0, 1)
        reward = reward + 2 * progress
        reward[info["success"]] = self.max_dense_reward
        return reward
