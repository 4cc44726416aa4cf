"""PinchClayCupHands (L3 deformable DX): pinch a clay ball into a small cup with a cavity, with two LEAP hands."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.clay.base import ClayTask

SIDES = ("left", "right")
# contacts are asked only with both hands' TCPs this close to the clay's middle (the query runs over every particle
# on the CPU, each side). A LEAP TCP lies ~10 cm out from the palm: the left hand's fingers against the ball's side
# with its TCP 15.1 cm from the clay's middle were missed at 0.15 m (seeds 102, 103)
HAND_NEAR = 0.25  # m


@register_task("PinchClayCupHands")
class PinchClayCupHandsEnv(ClayTask, ManiLadderEnv):
    """**Task:** a ball of clay (plastic: it keeps the shape it is pressed into) lies on the table between the two
    arms; with the two LEAP hands, one holding the ball's sides while the other's finger presses into its top, pinch it
    into a small cup: a cavity walled on all sides, standing on its own once the hands let go.

    **Randomisation:** the ball (particles of the clay library's 1.2 cm lattice within `ball_radius` of its middle:
    179 particles, 8.4 cm across) is scaled by a factor uniform in `clay_scale_range` (`Clay.reset`), turned by a yaw
    uniform in `clay_yaw_range` (its lattice's), its bottom centre uniform in x in `clay_x_range`, y in
    `clay_y_range`.

    **Success:** the clay holds a cavity at least `min_depth` deep with walls on all sides (`clay.cup_depth`: some
    particle's table point is the cavity's centre; its floor is the clay's top within `floor_radius` of it, and in
    every direction round it the sector `wall_arc` wide, out to `wall_radius`, holds clay standing at least
    `min_depth` above the floor); neither hand touches the clay (the cup stands on its own); and both hands touched
    the clay at one step of the episode (episode memory `held_both`: one held it while the other pressed).

    **Level 3:** against Level 1's PokeClayHand (one fingertip dent 1 cm deep, one hand, ~37 steps) and Level 2's
    clay tasks (PressClayFlat, StampClay: one press, IoU 0.5), and beside Level 3's MoldClayHand (one hand, a
    mould's walls shape the clay): the hands are the mould. A fingertip-sized punch (2.1 x 3.5 cm) pressed to 1.2 cm
    over the table into the free 7 cm high ball pushes it aside (no cup), while the same press with one side held by
    a plate leaves a cavity 3.3 cm deep (kinematic probes): the cup needs two hands at once, one holding a side, the
    other's finger pressed ~5.8 cm down the middle, slowly (at 3 mm a control step the finger plowed a crater 1.1-1.6
    cm deep; at 1.5 mm, 2.1-2.3 cm on seeds 100-104), a margin of 1-3 mm over the rule.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.25, 0.05, -0.2, 0.2)
    PARAMS = ("ball_radius", "min_depth", "floor_radius", "wall_radius", "wall_arc") + ClayTask.CLAY_LAYOUT_PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_ball(self.ball_radius, self.clay_config.spacing))
        self.memory.flag("held_both")  # both hands touched the clay at the same step
        # every reader of the particles within a step (the clay's own plastic `relax`, the episode memory, `evaluate`,
        # the observation and the reward) shares one read of them: `clay_points`
        self._read_points, self._points = self.clay.positions, None
        self.clay.positions = self.clay_points

    def clay_points(self) -> torch.Tensor:
        """The clay's particle centres, [B, N, 3] (`Clay.positions`), read once after each physics step, reset or
        state set and shared until the next (the read, one pose per particle, was 16 % of a random-action step's
        time at six reads a step)."""
        if self._points is None:
            self._points = self._read_points()
        return self._points

    def _after_simulation_step(self):
        super()._after_simulation_step()
        self._points = None

    def _step_action(self, action):
        action = super()._step_action(action)
        if self.gpu_sim_enabled:  # the GPU's poses are fetched after the control step's hooks (`relax`, memory)
            self._points = None
        return action

    def set_state_dict(self, state: dict, env_idx: torch.Tensor = None):
        super().set_state_dict(state, env_idx)
        self._points = None

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx)
        self._points = None

    def depth(self) -> torch.Tensor:
        """The deepest cavity walled on all sides (`clay.cup_depth`), m, [B]."""
        return clay.cup_depth(self.clay_points(), self.clay_config.radius, self.floor_radius, self.wall_radius,
                              np.radians(self.wall_arc))

    def top_centre(self) -> torch.Tensor:
        """The middle of the clay's top (its particles' mean xy, its highest top), [B, 3]."""
        points = self.clay_points()
        centre = points.mean(dim=1)
        centre[:, 2] = points[..., 2].amax(dim=1) + self.clay_config.radius
        return centre

    def hands_near(self) -> torch.Tensor:
        """Both hands' TCPs within `HAND_NEAR` of the clay's middle, [B]."""
        middle = self.clay_points().mean(dim=1)
        return torch.stack([torch.linalg.norm(self.ee.tcp(side).p - middle, dim=1) <= HAND_NEAR
                            for side in SIDES]).all(dim=0)

    def _update_memory(self):
        if self.memory["held_both"].all():
            return  # latched for good: spare the contact queries
        near = self.hands_near()
        if bool(near.any()):
            touched = [self.ee.touches(self.clay.spheres, side) for side in SIDES]
            self.memory.latch("held_both", near & touched[0] & touched[1])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        if "state" in self.obs_mode:
            obs.update(clay_points=self.clay_points().flatten(1), cup_depth=info["cup_depth"])
        return obs

    def evaluate(self):
        depth, held_both = self.depth(), self.memory["held_both"]
        is_cup = depth >= self.min_depth
        hands_off = torch.ones_like(is_cup)
        if bool((is_cup & held_both).any()):  # the contact query only when it can decide success
            hands_off = ~self.ee.touches(self.clay.spheres)
        return {"success": is_cup & held_both & hands_off, "cup_depth": depth, "is_cup": is_cup,
                "held_both": held_both, "hands_off": hands_off}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        top = self.top_centre()
        press = 1 - torch.tanh(5 * torch.linalg.norm(top - leap_fingertip(self.agent, prefix="right_"), dim=1))
        middle = self.clay_points().mean(dim=1)
        hold = 1 - torch.tanh(5 * torch.linalg.norm(middle - self.ee.tcp("left").p, dim=1))
        reward = press + hold + 2 * (info["cup_depth"] / self.min_depth).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
