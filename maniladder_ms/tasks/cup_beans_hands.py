"""CupBeansHands (L2 deformable DX, family ScoopBeans): the right LEAP hand scoops beans with a cupped palm and pours
them into a cup the left LEAP hand holds.

STATUS: UNFINISHED (session 16), NOT registered (no solver). Scene, rule (episode memory) and dense reward are built;
measured on seed 100 (scripts in the session-16 report, numbers here):
- a cupped palm-up right hand HOLDS beans: 40 beans dropped on the palm, after 40 steps and a 20 cm carry at 5 mm a
  step still on the hand: LEAP_SYNERGIES["cup"] (added: knuckles 0.6 rad, thumb swung 1.0) 36/40,
  HandoverBallHands' CRADLE_DISH 27/40, a deeper cup (knuckles 0.9) 34/40. Capacity is not the problem.
- a palm-up hand cannot reach a tray on the table: rolled palm-up (HandoverBallHands' roll, yaw -90 deg) at
  x -0.05, y -0.15, its TCP stops at z 0.32 m (the palm ~0.24 m up): right links 5 and 6 press on the table,
  joint 2 at 1.741 of its 1.763 rad limit, the palm tilts to 40 deg. The forearm hangs under a palm-up LEAP
  palm (~0.26 m), so "scoop palm-up" needs the beans ~0.25 m above the table, not in a tray on it.
- a top-down "grab then roll palm-up" takes none: hand lowered open over the pile (TCP 2-3 cm over the tray
  floor), closed to "power" or to cups (knuckles 1.2-1.5, side joints 0.1 towards the middle finger), lifted
  15 cm: 0 beans above 5 cm in all 4 tries, with a 1-bean layer (12 x 12 cm tray) and a 3-bean pile (7 x 7 cm)
  (why was not looked at in renders).
- a "dustpan" (palm vertical facing +y, fingers pointing down, curled 1.5 rad at the knuckles, 0.4 at PIP/DIP;
  reachable, right joints >= 1.07 rad from their limits) over a 13 x 9 cm tray (1.3 bean layers): the TCP stopped
  at z 0.062 m (target 0.035-0.05, the hand's lowest links ~3.2 cm under the TCP), pushed 2 cm, tilted back and
  lifted: 0 beans. The fingers never entered the tray: their MCP/PIP/DIP links lay on the table behind the tray's
  near wall (contacts with the table; fingertips at the wall, y -0.183, the mount 15 cm behind the TCP at y -0.323):
  curled this way the finger "floor" runs ~13 cm from the mount to ~1 cm short of the TCP, so the TCP must start
  >= 14 cm past the near wall, and the floor is longer than this tray (9 cm along the push) is deep.
What to try next: the dustpan scoop with its fingers placed in the pile: a tray open (or low-walled) on the hand's
side and >= ~20 cm along the push, a pile deeper than the fingers are thick (~2 cm; more beans or a heap against the
far wall), then tilt back to palm up ("cup") as the hand rises; or beans raised ~0.25 m (a tray on a stand, the palm
coming up under its open side). Either changes the scene, so the catalog row's description/plan should follow.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import LEAP_SYNERGIES
from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task  # noqa: F401 (register_task: once the solver passes)
from maniladder_ms.objects import containers
from maniladder_ms.objects.tabletop import build_tray
from maniladder_ms.solvers.bimanual import READY_ARM_JOINTS

from .scoop_beans_with_spoon import ScoopBeansTask

TRAY_INNER = (0.035, 0.035)  # half sizes (m) of the tray's floor: 150 beans of 4 mm lie ~3 deep (2.6 cm)
TRAY_WALL, TRAY_WALL_HEIGHT, TRAY_BASE = 0.006, 0.03, 0.005
CUP_DENSITY = 400.0  # a light plastic cup (PourGrainsHandToCup's)
# the left holds the cup: PourGrainsHandToCup's measured side grasp of its pourer (left Panda, thumb low, joint 7
# >= 0.8 rad from its limits); the right's joint 7 is at its limit for that grasp, so the right scoops
SCOOPER, HOLDER = "right", "left"
# the cupped palm (in the scooping hand's TCP frame: z out of the palm, which lies at z -0.08; x along the
# fingers): where carried beans rest, up to a bean or two over the raised fingers
PALM_BOX_CENTRE, PALM_BOX_HALF = (0.0, 0.0, -0.045), (0.075, 0.06, 0.04)
# the cupped palm the scooping hand carries beans in (LEAP_SYNERGIES["cup"]: 36 of 40 beans kept on a palm-up hand
# through a 20 cm carry)
CUP_SYNERGY = LEAP_SYNERGIES["cup"]


# @register_task("CupBeansHands")  -- not yet: no solver (module docstring)
class CupBeansHandsEnv(ScoopBeansTask, ManiLadderEnv):
    """**Task:** beans lie in a shallow tray in front of the right arm and a cup stands to the left. The left
    LEAP hand picks the cup up and holds it off the table; the right LEAP hand scoops beans out of the tray with
    its cupped palm, carries them over the cup and pours them in.

    **Randomisation:**
    - the tray (a 7 x 7 cm floor, 3 cm walls) stands at x in [-0.04, 0], y in [-0.16, -0.12], holding
      `bean_count` beans (granular spheres of radius `bean_radius`) packed from its floor (~3 layers) with a
      small random jitter;
    - the cup (plastic, inner radius 3.5 cm, 11 cm tall) stands at x in [-0.16, -0.1], y in [0.14, 0.2];
    - the left arm starts in a ready pose (`READY_JOINTS`: its hand raised above the cup, turned for a side
      grasp), the right at rest, plus the usual joint noise.

    **Success:** at least `min_beans` beans lie inside the cup's inner volume (below its rim) that the right
    hand carried: each of them lay in the right hand's cupped palm (`in_palm`: a box in its TCP frame over
    the palm and the raised fingers) at some step at which it was out of the tray (outside the tray's inner
    box, above its rim) and the right hand did not touch the tray (episode memory `carried`, one flag per
    bean); the left hand holds the cup (`ee.holds`) with its bottom at least `cup_lift` above the table, now
    and on every step since the first carried bean entered the cup (memory `cup_let_go`): the beans cannot
    be pushed or poured into a cup standing on the table, and the cup's rim is above the tray's.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.12, -0.25, 0.25)
    PARAMS = ("bean_count", "bean_radius", "min_beans", "cup_lift")
    # piles of beans: PhysX contact caches are not env state (as the pour tasks)
    RESTORES_NEED_FRESH_SCENE = True
    READY_JOINTS = {f"{HOLDER}_panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS[HOLDER], 1)}
    cup_shape = containers.cup(radius=0.035, height=0.11, wall=0.004)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.tray = build_tray(self.scene, "tray", TRAY_INNER, TRAY_WALL_HEIGHT, TRAY_WALL, TRAY_BASE,
                               color=(0.45, 0.6, 0.4, 1))
        self.cup = containers.build_container(self.scene, "cup", self.cup_shape, color=(0.8, 0.35, 0.3, 1),
                                              density=CUP_DENSITY)
        self.beans = particles.build_particles(self.scene, "beans", self.particle_config)
        self.memory.value("carried", self.bean_count)  # 1 where the bean lay in the right palm out of the tray
        self.memory.flag("cup_let_go")  # the cup not held off the table at a step since a carried bean entered it

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            # (x, y, z) uniform in [low, high] per env: the tray, then the cup
            low, high = torch.tensor([[-0.04, -0.16, 0.0], [-0.16, 0.14, 0.0]]), torch.tensor([[0.0, -0.12, 0.0], [-0.1, 0.2, 0.0]])
            tray, cup = (low + (high - low) * torch.rand(b, 2, 3)).unbind(dim=1)
            self.tray.set_pose(Pose.create_from_pq(tray))
            self.cup.set_pose(Pose.create_from_pq(cup))
            self.beans.set_positions(self.pile(tray))

    def pile(self, tray: torch.Tensor) -> torch.Tensor:
        """Bean positions [b, N, 3]: a square lattice (spacing 2.1 radii) filling the tray's floor layer by
        layer, jittered by 0.05 radius (as `particles.pack_in_container`)."""
        r = self.bean_radius
        spacing = 2.1 * r
        kx, ky = (int((half - 1.2 * r) // spacing) for half in TRAY_INNER)
        xy = np.stack(np.meshgrid(np.arange(-kx, kx + 1) * spacing, np.arange(-ky, ky + 1) * spacing), -1).reshape(-1, 2)
        layers = -(-self.bean_count // len(xy))
        z = np.repeat(TRAY_BASE + 1.05 * r + spacing * np.arange(layers), len(xy))[:, None]
        pts = np.concatenate([np.tile(xy, (layers, 1)), z], axis=1)[: self.bean_count]
        out = torch.tensor(pts, dtype=torch.float32, device=tray.device).expand(len(tray), -1, 3)
        out = out + (torch.rand(out.shape, device=tray.device) - 0.5) * 0.1 * r
        return out + tray[:, None]

    # ---- what the rule reads --------------------------------------------------------------------------
    def in_palm(self) -> torch.Tensor:
        """Beans in the right hand's cupped palm (a box in its TCP frame), [B, N]."""
        return particles.inside_box(self.beans.positions(), self.ee.tcp(SCOOPER), PALM_BOX_CENTRE, PALM_BOX_HALF)

    def in_tray(self) -> torch.Tensor:
        """Beans over the tray's floor below its rim (its inner box), [B, N]."""
        half = (TRAY_INNER[0], TRAY_INNER[1], TRAY_WALL_HEIGHT / 2)
        return particles.inside_box(self.beans.positions(), self.tray.pose, (0.0, 0.0, TRAY_WALL_HEIGHT / 2), half)

    def cup_held_up(self) -> torch.Tensor:
        return self.ee.holds(self.cup, HOLDER) & (self.cup.pose.p[:, 2] >= self.cup_lift)

    def _update_memory(self):
        carried = self.memory["carried"] > 0.5
        scooping = ~self.ee.touches(self.tray, SCOOPER)
        carried |= self.in_palm() & ~self.in_tray() & scooping[:, None]
        self.memory.store("carried", carried.float())
        self.memory.latch("cup_let_go", (self.in_cup() & carried).any(dim=1) & ~self.cup_held_up())

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   cup_held=info["cup_held"])
        if "state" in self.obs_mode:
            obs.update(tray_pose=self.tray.pose.raw_pose, cup_pose=self.cup.pose.raw_pose,
                       beans_positions=self.beans.positions().flatten(1))
        return obs

    def evaluate(self):
        delivery = self.delivery_metrics()
        held = self.ee.holds(self.cup, HOLDER)
        held_up = held & (self.cup.pose.p[:, 2] >= self.cup_lift)
        let_go = self.memory["cup_let_go"]
        return {
            "success": (delivery["beans_delivered"] >= self.min_beans) & held_up & ~let_go,
            **delivery,
            "beans_in_palm": self.in_palm().sum(dim=1),
            "cup_held": held,
            "cup_lifted": held_up,
            "cup_let_go": let_go,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # left: reach, hold and lift the cup; right: reach the tray, beans in the palm, carry over the cup; then
        # the carried beans in the cup
        mid = torch.tensor([0, 0, 0.05], device=self.device)
        reach_cup = 1 - torch.tanh(5 * torch.linalg.norm(self.cup.pose.p + mid - self.ee.tcp(HOLDER).p, dim=1))
        reach_tray = 1 - torch.tanh(5 * torch.linalg.norm(self.tray.pose.p - self.ee.tcp(SCOOPER).p, dim=1))
        lifted = info["cup_lifted"].float()
        loaded = (info["beans_in_palm"].float() / self.min_beans).clamp(0, 1)
        to_cup = torch.linalg.norm((self.ee.tcp(SCOOPER).p - self.cup.pose.p)[:, :2], dim=1)
        reward = 0.5 * (reach_cup + info["cup_held"].float()) + lifted + 0.5 * reach_tray + loaded
        reward += loaded * (1 - torch.tanh(5 * to_cup))
        reward += 2 * (info["beans_delivered"].float() / self.min_beans).clamp(0, 1) * lifted
        reward[info["success"]] = self.max_dense_reward
        return reward
