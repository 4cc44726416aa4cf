"""HangTowelOnHookHands (L3 deformable DX): two LEAP hands lift a towel by two corners and hang it on a small wall
hook by the cord loop at one of them."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.envs.memory import latch_held_by_both
from maniladder_ms.objects.tabletop import build_wall_hook, wall_hook_axis
from maniladder_ms.tasks.cloth.base import SIDES, lay_between_hands

ROWS = COLS = 8  # the towel's particle rows and columns
LOOP_PARTICLES = 7  # the cord loop's ring at the towel's (+x, +y) corner (`cloth.towel_with_loop`)
# the loop's links bend 25 times as stiffly as the sheet's (N m/rad, N m s/rad): a sewn-on hanging loop keeps its
# shape. With the sheet's 0.002 a ring held at the corner hangs closed, its two strands of beads side by side
# (measured with an 11-bead ring: a shaft pushed at the gap swung it aside); at 0.05 it stays an open ring
CORD_BEND_STIFFNESS, CORD_BEND_DAMPING = 0.05, 0.005
HOOK_COLOR = (0.55, 0.42, 0.3, 1)


@register_task("HangTowelOnHookHands")
class HangTowelOnHookHandsEnv(ManiLadderEnv):
    """**Task:** a towel with a cord loop sewn to one corner lies flat on the table between the two arms; a
    small hook sticks out of an upright board at the far side of the table, pointing up and at the robot. The
    LEAP hands take the towel by two opposite corners (the right one the corner with the loop), lift it, turn
    the loop to face the hook, carry it over the hook's tip and let go: the towel hangs from the hook by its loop.

    **Randomisation:**
    - the towel (`cloth.towel_with_loop(8, 8, 7)`: 8 x 8 particles 2.5 cm apart, 1 cm radius, and a ring of
      7 cord beads beyond one corner, 6.5 cm across between bead centres, its hole 4.5 cm; the loop's links
      bend `CORD_BEND_STIFFNESS`) lies flat, its centre at x uniform in [-0.14, -0.06], y uniform in
      [-0.03, 0.03], turned so the loop's corner is the right hand's: the diagonal through it 85-105 degrees
      from the x axis (`tasks/cloth/base.py`'s `lay_between_hands`, turned a half turn further);
    - the hook (a round shaft of radius `HOOK_RADIUS`, pitched `HOOK_TILT` up from -x, out of a board 8 cm
      wide) has its root at x uniform in [0.08, 0.12] (`HOOK_X_LOW`, `HOOK_X_SPAN`), y uniform in
      [-0.16, -0.10] (`HOOK_Y_LOW`, `HOOK_Y_SPAN`), height uniform in [0.38, 0.41] (`HOOK_HEIGHT_LOW`,
      `HOOK_HEIGHT_SPAN`).

    **Success:** the loop hangs on the hook (`cloth.loop_on_hook`: the ring of loop particles winds once round
    the shaft's line and its centre lies along the shaft between the board and the tip, the shaft being
    `hook_length` long); no particle within `table_gap` of the table (every particle's lowest point higher);
    both hands have let go (neither touches a towel particle, `ee.touches`); and at some step both hands held
    (`ee.holds`) a corner or the loop at once (each hand's corner particle or a loop bead; episode memory
    `towel_held`: the towel was carried by two hands, not dragged or flung onto the hook by one).

    **Level 3:** a rung up from Level 2's HangTowelOnBar (two grippers drape a towel over a 2 cm rod 40 cm
    long: 5 stages, ~190 steps, a drape anywhere along the rod counts): here the towel must go onto a 1 cm
    shaft through a 4.5 cm hole whose pose the hands do not set. 7 stages (both corners pinched; lifted ~50 cm
    up, 9 cm over the hook's tip; the loop turned about the vertical, up to 180 degrees, until its plane faces the
    shaft; lined up 4 cm in front of the tip, closed loop on the ring's particles, within ~1.5 cm of the hole's
    middle in both directions across the shaft; carried 9.5 cm along +x over the tip; the right hand lowers
    and lets go; the left lays the towel under the hook and lets go), the loop's pose perceived at every turn
    and line-up, and the 71-particle towel must end hanging free from the loop alone; demos take 287-446 steps (mean 307).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    cloth_config = cloth.ClothConfig(radius=0.010, cord_bend_stiffness=CORD_BEND_STIFFNESS,
                                      cord_bend_damping=CORD_BEND_DAMPING)
    PARAMS = ("hook_length", "table_gap")
    # towel start (centre plus the half diagonal, the loop's 7.5 cm beyond the right corner) and the hook's board
    TASK_REGION = (-0.28, 0.15, -0.26, 0.17)
    HOOK_X_LOW, HOOK_X_SPAN = 0.08, 0.04  # the hook root's x (the board's front face): uniform in [low, low + span]
    HOOK_Y_LOW, HOOK_Y_SPAN = -0.16, 0.06  # its y
    HOOK_HEIGHT_LOW, HOOK_HEIGHT_SPAN = 0.38, 0.03  # the root's height above the table
    HOOK_RADIUS = 0.005
    HOOK_TILT = np.deg2rad(20)  # the shaft pitched up from -x (pointing at the robot) by this
    BOARD_HALF = (0.01, 0.04)  # the board's half thickness (x) and half width (y)
    # the board reaches this far over the shaft's root: low, so the hand holding the loop over the shaft clears it
    BOARD_ABOVE = 0.03

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.towel_with_loop(ROWS, COLS, LOOP_PARTICLES, self.cloth_config.spacing)
        self.towel = cloth.build_cloth(self.scene, "towel", layout, self.cloth_config)
        corners = layout.named["corners"]
        self.hand_corners = {"left": corners[0], "right": corners[3]}  # the loop's corner is the right hand's
        self.ring = layout.named["loop"]
        # what the memory's holds look for: each hand's corner and the loop's beads (the right hand's pinch takes the
        # loop's first beads beside its corner); a check over all 71 particles made a control step 7 times as long
        self.hold_parts = [self.towel.spheres[i] for i in [*self.hand_corners.values(), *self.ring[1:]]]
        # the board reaches from the table (or into it, for a lower hook) to BOARD_ABOVE over the shaft
        below = self.HOOK_HEIGHT_LOW + self.HOOK_HEIGHT_SPAN
        self.hook_axis = torch.tensor(wall_hook_axis(self.HOOK_TILT), device=self.device)
        self.hook = build_wall_hook(self.scene, "hook", self.hook_length, self.HOOK_RADIUS, self.HOOK_TILT,
                                    self.BOARD_HALF,
                                    (below, self.BOARD_ABOVE), HOOK_COLOR)
        self.memory.flag("towel_held")  # both hands held a corner or the loop at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            lay_between_hands(self.towel, b, turn=np.pi)  # the loop's corner (+x, +y) the right hand's
            root = torch.stack([torch.rand(b) * self.HOOK_X_SPAN + self.HOOK_X_LOW,
                                torch.rand(b) * self.HOOK_Y_SPAN + self.HOOK_Y_LOW,
                                torch.rand(b) * self.HOOK_HEIGHT_SPAN + self.HOOK_HEIGHT_LOW], dim=1)
            self.hook.set_pose(Pose.create_from_pq(root))

    def hook_tip(self) -> torch.Tensor:
        """The centre of the hook's tip (its shaft's end), [B, 3]."""
        return self.hook.pose.p + self.hook_axis * self.hook_length

    def corner_particles(self) -> dict:
        """The corner particle (actor) each hand takes, keyed by side."""
        return {side: self.towel.spheres[i] for side, i in self.hand_corners.items()}

    def _update_memory(self):
        latch_held_by_both(self, "towel_held", self.hold_parts)

    def evaluate(self):
        points = self.towel.positions()
        axis = self.hook_axis
        on_hook = cloth.loop_on_hook(points, self.ring, self.hook_tip(), axis, self.hook_length)
        lowest = points[..., 2].amin(dim=1) - self.cloth_config.radius
        off_table = lowest > self.table_gap
        touching = self.ee.touches(self.towel.spheres)
        held = self.memory["towel_held"]
        ring_to_tip = torch.linalg.norm(points[:, self.ring].mean(dim=1) - self.hook_tip(), dim=1)
        return dict(success=on_hook & off_table & ~touching & held, on_hook=on_hook, off_table=off_table,
                    lowest=lowest, is_touching=touching, towel_held=held, ring_to_tip=ring_to_tip)

    def _get_obs_extra(self, info: dict):
        tcps = {side: self.ee.tcp(side) for side in SIDES}
        obs = {f"{side}_tcp_pose": tcp.raw_pose for side, tcp in tcps.items()}
        if "state" in self.obs_mode:
            corners = self.corner_particles()
            obs.update(towel_points=self.towel.positions().flatten(1), hook_tip=self.hook_tip(),
                       **{f"{side}_tcp_to_corner": corners[side].pose.p - tcp.p for side, tcp in tcps.items()})
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        held = info["towel_held"]
        for side, particle in self.corner_particles().items():
            reach = torch.linalg.norm(particle.pose.p - self.ee.tcp(side).p, dim=1)
            reward += torch.where(held, 1.0, 1 - torch.tanh(5 * reach))
        reward += held.float()
        reward += held.float() * (1 - torch.tanh(5 * info["ring_to_tip"]))
        reward += (info["on_hook"] & held).float() * (1 + info["off_table"].float())
        reward[info["success"]] = self.max_dense_reward
        return reward
