"""HangTowelOnRackHand (L2 deformable SX): one LEAP hand pinches a towel in its middle, lifts it and hangs it over
a rack's bar (the HangTowel family's scene and rule, tasks/hang_towel.py; a thin subclass of `HangTowelEnv`).

NOT BUILT YET (session 16, helper/rackhand): not registered (the `register_task` line below is commented out)
until its solver passes 45 of seeds 100-149. Session 16: solver 32/50 on seeds 100-149 (the failing seeds in the catalog comment).
Dev seeds: 100-109 8/10 and 0-9 8/10 (successes in 206-247 steps, horizon 300).
What works: the middle pinch (`gather_open`: the open scissor spread to +-0.5 rad, the tips pressed 1 cm into the
sheet at its middle, fingers along the towel's rows, swung together) lifts the whole towel on every dev seed (the
tips drag the two middle particles of the middle row together by friction); carrying the hanging bundle over the
bar and lowering it onto the rod gives a drape of ~0.3-0.4 of the particles on each side with ~0.3 on top of the rod.
What fails: after the release the drape is not stable: particles roll over the rod (the spheres roll; the rod's
friction holds little), so the towel drifts by about one row (0.1 of its particles) towards one side in the 10-40
steps after the release, and sometimes slides off entirely (seed 6: 0.36 / 0.26 after the rise, then all on the near
side); a one-row drift takes a 0.4 / 0.4 drape below min_side on one side.
Tried (dev seeds, no better than 8/10, not kept): the pinched pair turned across the bar (a 60-120 degree wrist
turn; the tips then straddle the rod; 1-3/8, slower, past the horizon on some); dragging the bundle over the rod at a
lower carry height (3/8); pinch released 1.2 cm over the rod's top or pressed onto it (same); balancing on the
fraction of all particles on each side instead of those hanging (5/8, with the faster lowering); aiming the balance at
the far side 0.06 heavier (the near side gained on several seeds: 5/10); gentler release (ramped opening, or the
plain scissor_open with 20 steps' wait: 4/8-8/10); release only after 8 balanced steps (8/10); a re-pinch when a side
is short right after the opening (8/10: the drift comes later, during the rise and the wait).
Session 17 (helper/rackhand2; solver unchanged, still 32/50): a library check (cloth.drape_over_rod, its tests) shows
a clean wrap on the rod at rest stays put, so the drift comes from the drape the hand leaves. Measured before the
opening (dev seeds 100, 101, 103, 104 passing, 105, 108, 110, 114, 123, 132 failing; the solver as is: 4/10): the
towel is a tent, not a wrap: 0.26-0.59 of the particles lie above the bar's top (the middle rows along the rod, the
rest piled under the pinch; a clean middle wrap leaves ~0.2 there), failing seeds mostly 0.41-0.59, passing ones
0.26-0.36 (101, 104: ~0.5); on opening the pile drops to one side and kicks the towel along (110: near 0.25 -> 0.49
within the 8 opening steps, then off). The towel's mean x before the opening does not predict the side it goes.
Tried on those 10 seeds, one at a time (outcomes flip both ways with a 1 cm change: chaotic, none kept): the closed
pinch pressed 1 cm lower after balancing 5/10 (fixes 114, 132, breaks 100), 2 cm 3/10; pinch 2 cm past the axis and
1 cm down before opening 3/10; open, then withdraw 8 cm along the rod's axis before rising 4/10; opening held 25 steps,
then 10 cm along the axis at 4 mm/step 3/10; a shake before opening (+-2 cm along the axis, 3 x 10 steps, rebalanced)
3/10, (+-1.5 cm vertically) 5/10 (fixes 105, 114, breaks 101); the slow lowering stopped where the hanging sum
stops growing (drops 0.03 below its best; 5 mm back up) 5/10 (fixes 105, 114, breaks 100); dragging the carried bag
over the rod (lowered 5 cm on its near side to 2 cm over its top, where the far half already lies over the rod, then
3.5 cm past the axis): the whole bag piles on the rod's top (0.65 above it) and slides off on opening (110); a corner
pinch for a single-layer flag drape: the corners nearest the bar cannot be reached (the hand's body stalls on the
rack's bar, 3.4 cm above the corner) nor those nearest the robot (the arm stalls 16 cm up, at x -0.39); the middle
pinch (`gather_open`) at the middle of a side edge instead (centred on rows 4-5 x its two outer columns) reaches the
sheet but lets it slip during the lift (110).
Session 18 (helper/rackhand3; solver unchanged, still 32/50; dev seeds as session 17, solver 4/10): (a) the middle
pinch carried at 6 cm over the top on the near side, swept 6 cm past the axis, then sunk on the far side with a
closed-loop depth: the bundle slides over the rod whole (near 0.00, 0.99 on top), 0/1; (b) the same gather pinch at
the middle of the towel's edge nearest the bar (between its last two rows): a flat single-layer wrap when it
works (100: 0.38 / 0.43, 0.20 on top), but the pinch is unreachable where that edge lies within ~8 cm of the bar's
axis (the hand's body stalls on the rod: 104, 108, 114, 123, 132 never lifted): 1/10; at the edge nearest the robot
it lifts 7/10 but hangs as a tube that piles on the rod like the middle pinch (0/10 swept over, 0/7 lower down);
(c) with the rack moved 6 cm further (bar x 0.06-0.12, a scene change, not committed) the far-edge pinch reaches on
every seed; carried 25 cm over the top to above the axis, lowered to 8 cm over it, then slid 4 mm/step out and down
to 5.4 cm past the axis until far >= near (near > 0.1, pinch below the top): dev 7/10 (8/10 lowered 3 cm past the
axis), but seeds 100-149 30/50 (successes 219-278 steps): the successes are clean (0.40 / 0.40, 0.20 on top), the
failures again a pile (0.45-0.77 on top before the opening; pulling the pinch 4 cm further down does not move it:
0/3). Next: the pile is the lever for both pinches: detect it before opening (top fraction > 0.35, the pinch still
holds) and re-drape (lift off, lower again: ~70% each try), which needs faster phases to fit the horizon.
Session 17's next: the pile must leave the rod's top before the fingers open (a drape with ~0.2 on top, ~0.4 per side): e.g. a
second contact that strokes the sheet down both sides of the rod while the pinch holds (the open thumb or palm), a
towel taken off-centre so only one layer folds over the rod (the pinch then lowered down the far side, as
HangTowelOnBar's corners: needs a pinch that holds at an edge), or a scene change (towel or rack placed so a corner
is reachable) with a catalog comment.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import LEAP_SYNERGIES
from maniladder_ms.envs import register_task  # noqa: F401 (the task is not registered yet)
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.hang_towel import ROWS, HangTowelEnv


# @register_task("HangTowelOnRackHand")  -- not yet: solver below the bar on seeds 100-149 (module docstring)
class HangTowelOnRackHandEnv(HangTowelEnv):
    """**Task:** a towel lies flat on the table in front of a towel rack (a horizontal bar along y on two
    posts); the LEAP hand pinches the towel in its middle, lifts it off the table, carries it over the bar,
    lowers it onto the bar so it hangs down on both sides, and lets go.

    **Randomisation:**
    - the rack (bar top 20 cm above the table, a 2 cm rod 40 cm long between its posts) stands with its
      axis at x uniform in [0.0, 0.06], y uniform in [-0.05, 0.05];
    - the towel (`cloth.towel(10, 8)`: 10 x 8 particles 2.5 cm apart, particles of 10 mm radius) lies flat,
      its centre at x uniform in [-0.22, -0.16], y uniform in [-0.05, 0.05], turned by a yaw uniform in
      +-30 degrees.

    **Success:** the towel hangs over the bar: at least `min_side` of its particles on each side of the bar
    (beyond the vertical plane through the bar's axis, and lower than the bar's top `bar_height`; the
    bar's radius is `bar_radius`; `cloth.hanging_fractions`); none on the table (every particle's lowest
    point more than `table_gap` above it); the hand has let go (touches no towel particle, `ee.touches`);
    and at some step the hand held (`ee.holds`) a towel particle while the whole towel was off the table
    (every particle's lowest point more than `table_gap` up; episode memory `lifted`: the towel was carried,
    not pushed or dragged onto the bar).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    HOLD_MEMORY = "lifted"
    TASK_REGION = (-0.38, 0.09, -0.28, 0.28)  # towel start (centre plus its half diagonal) and the rack with its feet

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("lifted")  # the hand held a towel particle while the towel was off the table

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            bar = torch.stack([torch.rand(b) * 0.06, torch.rand(b) * 0.1 - 0.05, torch.zeros(b)], dim=1)
            self.bar.set_pose(Pose.create_from_pq(bar))
            centre = torch.stack([torch.rand(b) * 0.06 - 0.22, torch.rand(b) * 0.1 - 0.05,
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(30)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))

    def _update_memory(self):
        if self.memory["lifted"].all():
            return
        lowest = self.towel.positions()[..., 2].amin(dim=1) - self.cloth_config.radius
        off = lowest > self.table_gap
        if off.any():
            self.memory.latch("lifted", off & self.ee.holds(self.towel.spheres))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            points = self.towel.positions()
            obs.update(towel_points=points.flatten(1), bar_pos=self.bar.pose.p,
                       tcp_to_centre=points.mean(dim=1) - self.ee.tcp().p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        lifted = self.memory["lifted"]
        reach = torch.linalg.norm(self.towel.positions().mean(dim=1) - self.ee.tcp().p, dim=1)
        reward = torch.where(lifted, 1.0, 1 - torch.tanh(5 * reach)) + lifted.float()
        sides = torch.stack([info["near_side"], info["far_side"]], dim=1)
        reward += 2 * (sides.amin(dim=1) / self.min_side).clamp(0, 1)
        reward += (info["hung"] & info["off_table"]).float() * 0.5
        reward[info["success"]] = self.max_dense_reward
        return reward


# the middle pinch: the open scissor spread to +-GATHER_SPREAD rad (LEAP side joints), the tips pressed
# GATHER_PRESS into the sheet around its middle, fingers along the towel's rows, swung together: the tips drag
# the two middle particles of the middle row together by friction and squeeze them (seeds 100-104: 5/5 lifted the
# towel; tips 5 mm higher or lower, a spread of 0.25 or 0.6 rad, or fingers along the columns: 0-1/5)
GATHER_SPREAD, GATHER_PRESS = 0.5, 0.01
CARRY_ABOVE = 0.17  # the pinch's height over the bar's top while carried: the bundle hangs 12-17 cm below it
LIFT_STEP, CARRY_STEP, LOWER_STEP = 0.012, 0.01, 0.008  # metres per control step
# the last SLOW_ABOVE of the lowering onto the bar go at SLOW_STEP: the whole way at 0.006 piled more of the towel
# on top of the rod than at 0.003 (5/8 vs 6/8 dev seeds)
SLOW_ABOVE, SLOW_STEP = 0.07, 0.003
SWING_STEPS = 10  # wait over the bar for the carried bundle to stop swinging
# with the pinch on the bar's top, shift it across the bar (GAIN metres per step per unit of imbalance, at most
# MAX_SHIFT) until the towel hangs evenly (near and far fractions within BALANCE_TOL) or BALANCE_STEPS
GAIN, MAX_SHIFT, BALANCE_TOL, BALANCE_STEPS = 0.005, 0.04, 0.04, 60
BALANCED_STEPS = 3  # in a row within BALANCE_TOL
RELEASE_STEPS, RISE = 8, 0.08


def gather_open() -> np.ndarray:
    """The LEAP joint targets of the open scissor with the index and middle fingers spread to +-GATHER_SPREAD."""
    q = LEAP_SYNERGIES["scissor_open"].copy()
    q[0], q[4] = -GATHER_SPREAD, GATHER_SPREAD
    return q


@register_solver("HangTowelOnRackHand", control_modes=TCP_DELTA_MODES)
def solve_hang_towel_on_rack_hand(env, seed: int) -> dict:
    """Pinch the towel's middle (`gather_open`, the scissor pressed into the sheet, fingers along its rows, swung
    together), lift it `CARRY_ABOVE` over the bar's top while turning the hand to yaw 0 (the pinched pair along
    the bar), carry it over the bar's axis, wait for the swing to stop, lower the pinch slowly onto the bar's top
    (the hanging bundle folds over the rod), shift it across the bar closed loop until the towel hangs evenly,
    open and rise."""
    with DrivenSolver.episode(env, seed) as s:
        task: HangTowelOnRackHandEnv = env.unwrapped
        n, device = task.num_envs, task.device
        points = task.towel.positions()
        cols = task.towel.layout.positions.shape[0] // ROWS
        rows_axis = points[:, cols] - points[:, 0]  # along the towel's rows (its local x)
        towel_yaw = torch.atan2(rows_axis[:, 1], rows_axis[:, 0])
        centre = points.mean(dim=1)
        centre[:, 2] = task.cloth_config.radius - GATHER_PRESS
        tcp, q = DrivenSolver.scissor_pose(centre, towel_yaw)
        s.set_ee("hand", gather_open(), steps=1)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"arm": (tcp, q)}, max_steps=30, pos_tol=0.003)
        s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        bar = task.bar.pose.p
        hand_yaw = torch.zeros_like(towel_yaw)
        top = task.bar_height + task.cloth_config.radius  # a particle's centre resting on the bar's top

        def tcp_for(x, y, z):  # the TCP pose placing the pinch at (x, y, z), hand at yaw 0
            return DrivenSolver.scissor_pose(torch.stack([x, y, torch.as_tensor(z, device=device).expand(n)], dim=1),
                                             hand_yaw)

        high, q2 = tcp_for(centre[:, 0], centre[:, 1], top + CARRY_ABOVE)
        glide(s, {"arm": (s.tcp().p.clone(), high, q)}, step_length=LIFT_STEP, settle_steps=5)
        s.move({"arm": (high, q2)}, max_steps=80, pos_tol=0.01, rot_tol=0.05)
        over, _ = tcp_for(bar[:, 0], bar[:, 1], top + CARRY_ABOVE)
        glide(s, {"arm": (s.tcp().p.clone(), over, q2)}, step_length=CARRY_STEP, settle_steps=10)
        for _ in range(SWING_STEPS):
            s.step()
        near, _ = tcp_for(bar[:, 0], bar[:, 1], top + SLOW_ABOVE)
        low, _ = tcp_for(bar[:, 0], bar[:, 1], top)
        glide(s, {"arm": (over, near, q2)}, step_length=LOWER_STEP, settle_steps=0)
        glide(s, {"arm": (near, low, q2)}, step_length=SLOW_STEP, settle_steps=5)
        shift = torch.zeros(n, device=device)
        streak = 0
        for _ in range(BALANCE_STEPS):
            sides = task.hanging()
            imbalance = sides[:, 0] - sides[:, 1]  # near side heavier: move the pinch to the far side
            streak = streak + 1 if bool((imbalance.abs() < BALANCE_TOL).all()) else 0
            if streak >= BALANCED_STEPS:
                break
            shift = (shift + GAIN * imbalance).clamp(-MAX_SHIFT, MAX_SHIFT)
            low, _ = tcp_for(bar[:, 0] + shift, bar[:, 1], top)
            s.step({"arm": (low, q2)})
        s.set_ee("hand", gather_open(), steps=RELEASE_STEPS)
        glide(s, {"arm": (low, s.above(low, RISE), q2)}, step_length=LIFT_STEP, settle_steps=5)
        s.hold_until_success()
        return s.info
