"""The HangTowel family (L2 deformable): hang a towel over a horizontal bar. HangTowelOnBar (DG): both
grippers lift a flat towel by two corners and drape it over the bar.

NOT BUILT YET (work in progress, helper/towelbar, session 14): HangTowelOnBar is not registered (the
`register_task` line below is commented out) until its solver passes 45 of seeds 100-149. Seeds 100-149:
36/50 (successes in 172-208 steps, mean 188; horizon 300). Failures, by kind (seeds 102, 106, 112, 120, 122,
123, 127 diagnosed): (1) a corner pinch misses or slips (corners never held by both at once, or the towel
dropped on the near side: 102, 120, 122, 123); a re-aimed second pinch (open to 4 cm, approach 4 cm above the
corner where it lies now, close) did not fix 122 / 123 and was dropped, nor did pinching 3 mm above the particle centre (FoldTowelInHalf's
GRASP_ABOVE: 102, 120, 122, 123 still fail; in 102 / 120 both corners were held, then one slipped and the
towel fell on the near side); (2) after the release the towel's
far part lies over a finger and the backing-off hand lifts it off the bar again (106, 112: far side 0-6%);
(3) the towel slides off to the far side onto the table after the release (127). Tried (dev seeds 100-120):
release 6 cm past the rod 4 cm under its top (the hand bodies rest on the towel over the rod and drag it
when backing off), 9 cm past / 2 cm under (far side too heavy), opening only to 4 cm at the release (the
back-off drags the corner), sinking the opened hands 5 cm before backing off (no better); kept: 11 cm past,
1 cm over the top, full opening, back-off along the corner's outward diagonal, then rise.
Next steps: a release that cannot catch the sheet (turn the wrists so the fingers close along y before the
lowering: the hand bodies then reach only 3.2 cm along x, but at 17.5 cm between the corners the two hands
then overlap by ~3 cm in y: needs a 10-column towel); a closed-loop check of the sides before opening.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import top_down_quat
from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task  # noqa: F401 (the task is not registered yet)
from maniladder_ms.envs.memory import latch_held_by_both
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.tabletop import build_towel_bar
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver

ROWS, COLS = 10, 8  # rows along the towel's local x (across the bar), columns along its local y (along the bar)
BAR_HALF_LENGTH = 0.2  # the rod runs 20 cm to each side of its middle, posts under its ends
BAR_COLOR = (0.62, 0.62, 0.66, 1)
BAR_AXIS = (0.0, 1.0, 0.0)  # the rod lies along y: its sides are -x (the robot's, the towel's start) and +x
SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
# the towel corner each arm takes (towel's named corners: 2 (+x, -y), 3 (+x, +y)): the two nearest the bar
CORNER = {"left": 3, "right": 2}


class HangTowelEnv(ManiLadderEnv):
    """The HangTowel family's scene and rule: a towel (a particle grid) and a fixed horizontal bar along y;
    the rule counts the particles hanging on each side of the bar (`cloth.hanging_fractions`), checks that
    none rests on (or within `table_gap` of) the table and that the end effectors let go. Variants set the
    agent and the start, and what memory the rule adds (how the towel must have been taken)."""

    max_dense_reward = 6
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("bar_height", "bar_radius", "min_side", "table_gap")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.towel(ROWS, COLS, self.cloth_config.spacing)
        self.towel = cloth.build_cloth(self.scene, "towel", layout, self.cloth_config)
        self.bar = build_towel_bar(self.scene, "bar", self.bar_height, self.bar_radius, BAR_HALF_LENGTH, BAR_COLOR)

    def hanging(self, points: torch.Tensor | None = None) -> torch.Tensor:
        """Fractions of the towel's particles (`points`, default: their positions now) hanging on the near (-x)
        and far (+x) side of the bar, [B, 2]."""
        points = self.towel.positions() if points is None else points
        return cloth.hanging_fractions(points, self.bar.pose.p, torch.tensor(BAR_AXIS), self.bar_height)

    def evaluate_hang(self) -> dict:
        points = self.towel.positions()
        sides = self.hanging(points)
        lowest = points[..., 2].amin(dim=1) - self.cloth_config.radius
        touching = self.ee.touches(self.towel.spheres)
        hung = (sides >= self.min_side).all(dim=1)
        off_table = lowest > self.table_gap
        return dict(near_side=sides[:, 0], far_side=sides[:, 1], hung=hung, lowest=lowest, off_table=off_table,
                    is_touching=touching, success=hung & off_table & ~touching)


# @register_task("HangTowelOnBar")  -- not yet: solver 36/50 on seeds 100-149 (module docstring)
class HangTowelOnBarEnv(HangTowelEnv):
    """**Task:** a towel lies flat on the table in front of a horizontal bar (a rod along y on two posts);
    each gripper takes the towel's corner on its side of the edge nearest the bar, together they lift the
    towel, carry it over the bar and lower it on the far side, so it hangs over the bar, and let go.

    **Randomisation:**
    - the bar (top 20 cm above the table, a 2 cm rod 40 cm long between its posts) stands with its axis at
      x uniform in [-0.06, -0.02], y 0;
    - the towel (`cloth.towel(10, 8)`: 10 x 8 particles 2.5 cm apart, 22.5 cm across the bar by 17.5 cm
      along it between particle centres, particles of 10 mm radius) lies flat on the robot's side of the
      bar, its edge nearest the bar 10-13 cm (uniform) short of the bar's axis, centred at y uniform in
      [-0.03, 0.03], turned by a yaw uniform in +-15 degrees.

    **Success:** the towel hangs over the bar: at least `min_side` of its particles on each side of the bar
    (beyond the vertical plane through the bar's axis, and lower than the bar's top `bar_height`; the
    bar's radius is `bar_radius`; `cloth.hanging_fractions`); none on the table (every particle's lowest
    point more than `table_gap` above it); both grippers have let go (neither touches a towel particle,
    `ee.touches`); and at some step both grippers held (`ee.holds`) a corner particle of the towel at once
    (episode memory `corners_held`: the towel was carried by two corners, not dragged over by one arm).

    **Why Level 2:** its Level-1 DG suite-mate SpreadTowelBimanual pulls a towel's two corners back over
    the table, 8 cm up, and lays them down (2 stages, horizon 150, a 75% coverage target, T = 10 log10 N + 2).
    Here the towel leaves the table: 5 stages (both corners pinched; lifted until the pinches are 24 cm up,
    4 cm over the 20 cm bar; carried 22-25 cm over it, the towel dragging up and over the 2 cm rod; lowered
    to 1 cm over its top on the far side; released and backed off without catching the sheet), both arms in
    lock-step the whole way (one arm ahead twists the sheet on the rod), and the result is judged after
    letting go: the 22.5 cm towel must leave at least 30% of its 80 particles hanging on each side of the rod
    (24 particles, three of its ten rows, below the rod's top; its halves hang ~10 cm) and clear the table on
    both sides; demos take ~230 steps of a 300-step horizon.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    TASK_REGION = (-0.45, 0.05, -0.26, 0.26)  # towel start (centre plus its half diagonal) and the bar with its feet

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("corners_held")  # both grippers held a towel corner at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            bar_x = torch.rand(b) * 0.04 - 0.06
            self.bar.set_pose(Pose.create_from_pq(torch.stack([bar_x, torch.zeros(b), torch.zeros(b)], dim=1)))
            half = (ROWS - 1) / 2 * self.cloth_config.spacing
            centre = torch.stack([bar_x - 0.10 - torch.rand(b) * 0.03 - half, torch.rand(b) * 0.06 - 0.03,
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(15)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))

    def corner_particles(self) -> dict:
        """The corner particle (actor) each arm takes, keyed by side."""
        return {side: self.towel.corner_spheres()[k] for side, k in CORNER.items()}

    def _update_memory(self):
        latch_held_by_both(self, "corners_held", self.towel.corner_spheres())

    def _get_obs_extra(self, info: dict):
        tcps = {side: self.ee.tcp(side) for side in SIDES}
        obs = {f"{side}_tcp_pose": tcp.raw_pose for side, tcp in tcps.items()}
        if "state" in self.obs_mode:
            corners = self.corner_particles()
            obs.update(towel_points=self.towel.positions().flatten(1), bar_pos=self.bar.pose.p,
                       **{f"{side}_tcp_to_corner": corners[side].pose.p - tcp.p for side, tcp in tcps.items()})
        return obs

    def evaluate(self):
        info = self.evaluate_hang()
        info["corners_held"] = self.memory["corners_held"]
        info["success"] = info["success"] & info["corners_held"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        held = self.memory["corners_held"]
        for side, particle in self.corner_particles().items():
            reach = torch.linalg.norm(particle.pose.p - self.ee.tcp(side).p, dim=1)
            reward += torch.where(held, 1.0, 1 - torch.tanh(5 * reach))
        reward += held.float()
        sides = torch.stack([info["near_side"], info["far_side"]], dim=1)
        reward += 2 * (sides.amin(dim=1) / self.min_side).clamp(0, 1)
        reward += (info["hung"] & info["off_table"]).float() * 0.5
        reward[info["success"]] = self.max_dense_reward
        return reward


FINGER_GAP_CMD = 0.2  # normalised gripper command: fingers 4 cm apart, around the corner particle only
CARRY_ABOVE_BAR = 0.04  # TCP height above the bar's top while the corners go over it
BEYOND_BAR = 0.11  # the corners are carried this far past the bar's axis: about half the towel's length
RELEASE_ABOVE_BAR = 0.01  # then lowered until the TCPs are this high above the bar's top (the hand bodies, turned
# along the corners' diagonals and reaching 3.7 cm above the TCP, clear the towel on the rod), and let go
LIFT_STEP, CARRY_STEP, LOWER_STEP = 0.01, 0.008, 0.006  # metres per control step
RELEASE_STEPS = 8
# after letting go, the opened hands back off horizontally along the corner's outward diagonal (the fingers'
# open gap: they slide past the corner particle without pushing it), then rise. Rising first lifted the towel's
# far edge, lying over a finger after the release, off the bar again (seed 106); backing off along x dragged
# the towel (a finger pushes the corner); with the TCPs 4 cm under the bar's top at the release the hand
# bodies rest on the towel over the rod and drag it
BACK_OFF, RISE = 0.08, 0.05


@register_solver("HangTowelOnBar", control_modes=TCP_DELTA_MODES)
def solve_hang_towel_on_bar(env, seed: int) -> dict:
    """Each arm pinches the corner on its side of the towel's edge nearest the bar top-down (fingers opened
    to 4 cm, closing along the corner's diagonal, as SpreadTowelBimanual), both close, rise together until
    the TCPs are `CARRY_ABOVE_BAR` over the bar's top, carry the corners over the bar to `BEYOND_BAR` past
    its axis (the towel slides up and over the rod), lower them to `RELEASE_ABOVE_BAR` over its top, open
    fully, back off along the corners' outward diagonals and rise."""
    with DrivenSolver.episode(env, seed) as s:
        task: HangTowelOnBarEnv = env.unwrapped
        n, device = task.num_envs, task.device
        points = task.towel.positions()
        corners = task.towel.layout.named["corners"]
        towel_axis = points[:, corners[2]] - points[:, corners[0]]
        towel_yaw = torch.atan2(towel_axis[:, 1], towel_axis[:, 0])
        bar = task.bar.pose.p
        grasps = []
        for side, sign in SIDES.items():
            p = task.corner_particles()[side].pose.p.clone()
            diagonal = float(np.arctan2(sign, 1.0))  # the corner's outward diagonal, local
            yaw = DrivenSolver.neutral_yaw(towel_yaw + diagonal + np.pi / 2, np.pi)
            approach = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
            grasps.append(Grasp(f"{side}_arm", f"{side}_gripper", p, top_down_quat(yaw, n, device), approach))
        for g in grasps:
            s.set_ee(g.ee, [FINGER_GAP_CMD], steps=0)
        reach(s, grasps)
        grasp_together(s, [g.ee for g in grasps])
        top = task.bar_height + CARRY_ABOVE_BAR
        high = {g.arm: torch.cat([g.p[:, :2], torch.full((n, 1), top, device=device)], dim=1) for g in grasps}
        glide(s, {g.arm: (g.p, high[g.arm], g.q) for g in grasps}, step_length=LIFT_STEP, settle_steps=5)
        over = {}
        for g in grasps:
            over[g.arm] = high[g.arm].clone()
            over[g.arm][:, 0] = bar[:, 0] + BEYOND_BAR
        glide(s, {g.arm: (high[g.arm], over[g.arm], g.q) for g in grasps}, step_length=CARRY_STEP, settle_steps=5)
        low = {arm: p - torch.tensor([0.0, 0.0, CARRY_ABOVE_BAR - RELEASE_ABOVE_BAR], device=device)
               for arm, p in over.items()}
        glide(s, {g.arm: (over[g.arm], low[g.arm], g.q) for g in grasps}, step_length=LOWER_STEP, settle_steps=5)
        for g in grasps:
            s.set_ee(g.ee, [1.0], steps=0)
        for _ in range(RELEASE_STEPS):
            s.step()
        up = torch.tensor([0.0, 0.0, RISE], device=device)
        points = task.towel.positions()
        away = {}
        for side in SIDES:
            outwards = task.corner_particles()[side].pose.p - points.mean(dim=1)
            outwards[:, 2] = 0
            away[f"{side}_arm"] = torch.nn.functional.normalize(outwards, dim=1) * BACK_OFF
        glide(s, {g.arm: (low[g.arm], low[g.arm] + away[g.arm], g.q) for g in grasps}, step_length=LOWER_STEP,
              settle_steps=0)
        glide(s, {g.arm: (low[g.arm] + away[g.arm], low[g.arm] + away[g.arm] + up, g.q) for g in grasps},
              step_length=LIFT_STEP, settle_steps=5)
        s.hold_until_success()
        return s.info
