"""SortCubesByColor (L3 rigid SG): put four coloured cubes into the bins of their own colours, leaving the
distractor cubes out of every bin."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.geometry.rotation_conversions import quaternion_to_matrix
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import spaced_xy, yaw_quat
from maniladder_ms.objects import build_tray

# the colours of the cubes to sort, each with a bin of its own colour (red, green, blue, yellow)
SORT_COLORS = [(0.85, 0.12, 0.12, 1), (0.12, 0.62, 0.2, 1), (0.12, 0.3, 0.85, 1), (0.92, 0.78, 0.08, 1)]
# bins of colours no cube has (purple, cyan) and cubes of colours no bin has (orange, white)
DISTRACTOR_BIN_COLORS = [(0.55, 0.18, 0.7, 1), (0.1, 0.72, 0.75, 1)]
DISTRACTOR_CUBE_COLORS = [(0.95, 0.48, 0.08, 1), (0.92, 0.92, 0.9, 1)]
# metres from the TCP: a cube the gripper holds has its centre within this (the Panda's fingers are 5 cm long);
# the contact query is costly on CPU, so it only runs for cubes this near
HOLD_RADIUS = 0.1


@register_task("SortCubesByColor")
class SortCubesByColorEnv(ManiLadderEnv):
    """**Task:** six bins stand in a two-by-three grid at the far side of the table, four of them in the colours
    of the four cubes to sort (red, green, blue, yellow) and two in colours no cube has (purple, cyan); six cubes
    (2 x `half_size`) lie on the near side, the four to sort and two distractors in colours no bin has (orange,
    white). Put each of the four cubes into the bin of its own colour and leave the distractors out of the bins.

    **Randomisation:**
    - the six bin colours are dealt to the six grid slots in a uniformly random order (which bin is where is
      known only from its colour); the grid's centre is shifted uniformly by up to `GRID_JITTER` = (2, 3) cm
      in (x, y) from `GRID_CENTRE`, its slots `BIN_PITCH` = 10 cm apart;
    - the six cube centres are uniform in x in `CUBE_X` = [-0.22, -0.06], y in `CUBE_Y` = [-0.26, 0.26], at
      least `CUBE_SPACING` = 7 cm apart, each with a uniform random yaw.

    **Success:** each of the four colour cubes lies inside the bin of its colour: its centre, in that bin's
    frame, within the bin's inner footprint (`bin_inner_half` from the centre on both axes) and below the top
    of its walls (`bin_wall_height`); no distractor cube lies inside any bin (the same test); and the gripper
    holds no cube (`ee.holds`).

    **Level 3:** (against Level 2's Stack6Blocks: five identical pick-and-place cycles to one site, the cubes'
    colours irrelevant, ~440 steps) four pick-and-place cycles (8 stages, ~390 steps), each to a different
    goal that only colour identifies: which cubes to move (4 of 6) and where (4 of 6 bins, dealt anew each
    episode: a colour-blind assignment is right with probability 1/360), each dropped into a 7 cm wide bin
    among neighbours 10 cm apart; one distractor cube in a bin or a cube in a wrong bin fails the episode.
    """

    TASK_REGION = (-0.25, 0.2, -0.3, 0.3)
    PARAMS = ("half_size", "bin_inner_half", "bin_wall_height")
    bin_wall_thickness = 0.006
    bin_base_thickness = 0.006
    GRID_CENTRE = (0.08, 0.0)  # the bin grid's centre (x, y) before jitter; two rows along x, three columns along y
    GRID_JITTER = (0.02, 0.03)  # the grid centre moves uniformly by up to this in x and y
    BIN_PITCH = 0.1  # metres between neighbouring bin centres
    CUBE_X, CUBE_Y = (-0.22, -0.06), (-0.26, 0.26)  # ranges of the cube centres
    CUBE_SPACING = 0.07  # least distance between two cube centres

    @property
    def num_sorted(self) -> int:
        return len(SORT_COLORS)

    @property
    def max_dense_reward(self) -> float:
        return 3 * self.num_sorted + 3

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        start = lambda i: Pose.create_from_pq([-0.1, 0.08 * i - 0.2, self.half_size]).sp
        self.cubes = [
            actors.build_cube(self.scene, half_size=self.half_size, color=c, name=f"cube_{i}", initial_pose=start(i))
            for i, c in enumerate(SORT_COLORS)
        ]
        self.distractor_cubes = [
            actors.build_cube(self.scene, half_size=self.half_size, color=c, name=f"distractor_cube_{i}",
                              initial_pose=start(i + self.num_sorted))
            for i, c in enumerate(DISTRACTOR_CUBE_COLORS)
        ]
        # bins[i] matches cubes[i] for i < num_sorted; the last ones are the distractor bins
        inner = (self.bin_inner_half, self.bin_inner_half)
        self.bins = [
            build_tray(self.scene, f"bin_{i}", inner, self.bin_wall_height, self.bin_wall_thickness,
                       self.bin_base_thickness, color=c)
            for i, c in enumerate(SORT_COLORS + DISTRACTOR_BIN_COLORS)
        ]
        self.all_cubes = self.cubes + self.distractor_cubes

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            # grid slots: rows at x = centre -+ pitch / 2, columns at y = centre - pitch, centre, centre + pitch
            rows, cols = torch.meshgrid(torch.tensor([-0.5, 0.5]), torch.tensor([-1.0, 0.0, 1.0]), indexing="ij")
            slots = torch.stack([rows.flatten(), cols.flatten()], dim=1) * self.BIN_PITCH  # (6, 2)
            centre = torch.tensor(self.GRID_CENTRE) + (2 * torch.rand(b, 2) - 1) * torch.tensor(self.GRID_JITTER)
            order = torch.argsort(torch.rand(b, len(self.bins)), dim=1)  # bin i goes to slot order[:, i]
            for i, bin_ in enumerate(self.bins):
                xy = centre + slots[order[:, i]]
                bin_.set_pose(Pose.create_from_pq(torch.cat([xy, torch.zeros(b, 1)], dim=1)))
            xy = spaced_xy(b, len(self.all_cubes), (self.CUBE_X[0], self.CUBE_Y[0]), (self.CUBE_X[1], self.CUBE_Y[1]),
                           self.CUBE_SPACING)
            for i, cube in enumerate(self.all_cubes):
                xyz = torch.cat([xy[:, i], torch.full((b, 1), self.half_size)], dim=1)
                cube.set_pose(Pose.create_from_pq(xyz, yaw_quat(torch.rand(b) * np.pi / 2)))

    def _inside(self) -> torch.Tensor:
        """(b, cubes, bins) whether each cube's centre lies within each bin's inner footprint and below its
        wall tops (cubes and bins in the order of `all_cubes` and `bins`)."""
        cube_p = torch.stack([c.pose.p for c in self.all_cubes], dim=1)  # (b, c, 3)
        bin_p = torch.stack([b.pose.p for b in self.bins], dim=1)  # (b, n, 3)
        bin_r = quaternion_to_matrix(torch.stack([b.pose.q for b in self.bins], dim=1))  # (b, n, 3, 3)
        # the cube centres in each bin's frame: R^T (p - t)
        local = torch.einsum("bnji,bcnj->bcni", bin_r, cube_p[:, :, None] - bin_p[:, None])
        return (local[..., :2].abs() <= self.bin_inner_half).all(dim=-1) & (local[..., 2] < self.bin_wall_height)

    def _held_cubes(self) -> torch.Tensor:
        """(b, 6) whether the gripper holds each cube (sorted cubes first); the contact query runs only for
        cubes within HOLD_RADIUS of the TCP."""
        tcp = self.ee.tcp().p
        held = torch.zeros(len(tcp), len(self.all_cubes), dtype=torch.bool, device=self.device)
        for i, cube in enumerate(self.all_cubes):
            near = torch.linalg.norm(cube.pose.p - tcp, dim=1) < HOLD_RADIUS
            if near.any():
                held[:, i] = near & self.ee.holds(cube)
        return held

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            # cube i's bin is bin i (i < 4); the distractors follow
            obs.update(cube_poses=torch.cat([c.pose.raw_pose for c in self.all_cubes], dim=1),
                       bin_poses=torch.cat([b.pose.raw_pose for b in self.bins], dim=1))
        return obs

    def evaluate(self):
        inside = self._inside()
        k = torch.arange(self.num_sorted)
        sorted_ = inside[:, k, k]  # (b, 4): cube i in bin i
        wrong_bin = inside[:, : self.num_sorted].clone()
        wrong_bin[:, k, k] = False
        distractor_in_bin = inside[:, self.num_sorted:].any(dim=2).any(dim=1)
        held = self._held_cubes()
        all_sorted = sorted_.all(dim=1)
        return {
            "success": all_sorted & ~distractor_in_bin & ~held.any(dim=1),
            "all_sorted": all_sorted,
            "num_sorted": sorted_.sum(dim=1),
            "cube_sorted": sorted_,
            "any_wrong_bin": wrong_bin.any(dim=2).any(dim=1),
            "distractor_in_bin": distractor_in_bin,
            "cube_held": held,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # progress: cubes in their own bins; shaping: reach the nearest unsorted colour cube, hold it, carry it
        # above its bin; penalties for a distractor or a cube in a wrong bin
        sorted_ = info["cube_sorted"]
        held = info["cube_held"][:, : self.num_sorted] & ~sorted_
        cube_p = torch.stack([c.pose.p for c in self.cubes], dim=1)  # (b, 4, 3)
        dist = torch.linalg.norm(cube_p - self.ee.tcp().p[:, None], dim=2)
        reach = 1 - torch.tanh(5 * torch.where(sorted_, torch.full_like(dist, 10), dist).min(dim=1).values)
        above = torch.stack([b.pose.p for b in self.bins[: self.num_sorted]], dim=1)
        above[..., 2] += self.bin_wall_height + 2 * self.half_size
        carry = (1 - torch.tanh(5 * torch.linalg.norm(above - cube_p, dim=2))) * held
        reward = 3 * info["num_sorted"].float() + reach + held.any(dim=1).float() + carry.max(dim=1).values
        reward -= 3 * (info["distractor_in_bin"] | info["any_wrong_bin"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
