"""CupBeansHands (L2 deformable DX): one LEAP hand sweeps beans off a ledge into the other's cupped palm, then holds a
cup while the palm pours them in."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects import containers
from maniladder_ms.objects.tabletop import build_raised_tray
from maniladder_ms.agents.poses import READY_ARM_JOINTS

from .base import ScoopBeansTask

# The ledge the beans are swept off: a raised tray, its 14 x 12 cm floor 38 cm up (palm-up the right TCP goes no
# lower than ~0.34), 3 cm walls, a 6 mm lip at -y; its floor a 1 cm slab overhanging the stand by 4 cm at -y, so the
# right's fingertips go in under the edge (without it the swept beans fell between the tips and the stand's face:
# 5-11 caught, with it 20-26)
TRAY_INNER = (0.07, 0.06)  # half sizes (m) of the tray's floor
TRAY_WALL, TRAY_WALL_HEIGHT, TRAY_LIP = 0.006, 0.03, 0.006
TRAY_FLOOR = 0.38  # the floor's top face above the table
TRAY_OVERHANG, TRAY_SLAB = 0.04, 0.01  # the floor slab's -y edge this far in front of the stand's face; its thickness
# the beans start packed in a PILE_DEPTH band (along y) round PILE_Y on the floor (tray frame), ~2.4 layers, the
# partial top layer at the far wall: the middle 8 cm (3.3 layers) lost 1-3 beans over the lip in 120 idle steps on
# each of seeds 100-109, this band 0-1
PILE_DEPTH, PILE_Y = 0.09, 0.015
# the pile's lattice, in bean radii (as `particles.pack_in_container`): spacing, clearance from the floor's edges,
# the first layer's centres above the floor, and the jitter's width
PILE_SPACING, PILE_CLEARANCE, PILE_LIFT, PILE_JITTER = 2.1, 1.2, 1.05, 0.1
CUP_DENSITY = 400.0  # a light plastic cup
# the left holds the cup with the left hand's measured side grasp (`solvers.side_grasps`: left Panda, thumb low,
# joint 7 >= 0.8 rad from its limits); the right's joint 7 is at its limit for that grasp, so the right scoops
SCOOPER, HOLDER = "right", "left"
# the cupped palm (in the scooping hand's TCP frame: z out of the palm, which lies at z -0.08; x along the
# fingers; y across them, the thumb at -y): where carried beans rest, up to a bean or two over the raised fingers.
# Across the hand it spans the measured palm and finger links (collision boxes, TCP frame: y -0.034..0.094; the
# palm's face at z -0.081): centred on y 0 it left out beans on the ring finger's side
PALM_BOX_CENTRE, PALM_BOX_HALF = (0.0, 0.03, -0.045), (0.075, 0.065, 0.04)


@register_task("CupBeansHands")
class CupBeansHandsEnv(ScoopBeansTask, ManiLadderEnv):
    """**Task:** beans lie on a ledge (a raised tray) in front of the right arm and a cup stands to the left. The
    beans must reach the cup by way of the right LEAP hand's cupped palm, and the left LEAP hand must hold the
    cup off the table while they go in. The solver's way: the right palm waits under the ledge's overhanging
    edge while the left hand, flat as a blade, sweeps the beans off into it; the left then picks the cup up and
    holds it, and the right carries its load over the cup and tips it in.

    **Randomisation:**
    - the tray (a ledge on a fixed stand: its 14 x 12 cm floor 38 cm above the table, a 1 cm slab overhanging
      the stand by 4 cm on the right hand's (-y) side, 3 cm walls, a 6 mm lip on that side) stands at x in
      `tray_x_range`, y in `tray_y_range`, holding `bean_count` beans (granular spheres of
      radius `bean_radius`) packed in a 9 cm band (along y) 1.5 cm behind the floor's middle with a small
      random jitter;
    - the cup (plastic, inner radius 3.5 cm, 11 cm tall) stands at x in `cup_x_range`, y in `cup_y_range`;
    - the left arm starts in a ready pose (`READY_JOINTS`: its hand raised above the cup, turned for a side
      grasp), the right at rest, plus the usual joint noise.

    **Success:** at least `min_beans` beans lie inside the cup's inner volume (below its rim) that the right
    hand carried: each of them lay in the right hand's cupped palm (`in_palm`: a box in its TCP frame over
    the palm and the raised fingers) at some step at which it was out of the tray (outside the tray's inner
    box, above its rim) and the right hand did not touch the tray (episode memory `carried`, one flag per
    bean); the left hand holds the cup (`ee.holds`) with its bottom at least `cup_lift` above the table, now
    and on every step since the first carried bean entered the cup (memory `cup_let_go`): the beans cannot
    be pushed or poured into a cup standing on the table, and the cup's rim is above the tray's.

    **Level 2:** (against Level 1's PourGrainsHandToCup, the same hands, cup and a granular load: 3 stages, each
    hand side-grasps a vessel, lift, tilt the glass, ~258 steps, the grains kept in a rigid glass) 7 stages in ~604
    steps: the right rolls palm-up under the ledge's edge while the left turns into a blade, the sweep, the
    left's retreat without dragging the catch off, the cup's side grasp and lift, its carry round the ledge's
    stand, the right's carry of loose beans on an open palm (~a quarter of the catch rolls off between the
    sweep and the pour), the pour off the fingers into a 7 cm mouth. The hands must share the space in front
    of the ledge in turn, and a bean counts only if it lay in the palm away from the tray.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.12, -0.25, 0.25)
    PARAMS = ("bean_count", "bean_radius", "min_beans", "cup_lift", "tray_x_range", "tray_y_range", "cup_x_range",
              "cup_y_range")
    # piles of beans: PhysX contact caches are not env state (as the pour tasks)
    RESTORES_NEED_FRESH_SCENE = True
    READY_JOINTS = {f"{HOLDER}_panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS[HOLDER], 1)}
    cup_shape = containers.cup(radius=0.035, height=0.11, wall=0.004)
    # where things stand: the catalog's tray_x_range / tray_y_range (the tray's centre: there the right hand at
    # rest clears its stand) and cup_x_range / cup_y_range (the cup's bottom centre)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.tray = build_raised_tray(self.scene, "tray", TRAY_INNER, TRAY_WALL_HEIGHT, TRAY_LIP, TRAY_WALL, TRAY_FLOOR,
                                      color=(0.45, 0.6, 0.4, 1), overhang=TRAY_OVERHANG, slab=TRAY_SLAB)
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
            (tx, ty), (cx, cy) = (self.tray_x_range, self.tray_y_range), (self.cup_x_range, self.cup_y_range)
            low = torch.tensor([[tx[0], ty[0], 0.0], [cx[0], cy[0], 0.0]])
            high = torch.tensor([[tx[1], ty[1], 0.0], [cx[1], cy[1], 0.0]])
            tray, cup = (low + (high - low) * torch.rand(b, 2, 3)).unbind(dim=1)
            self.tray.set_pose(Pose.create_from_pq(tray))
            self.cup.set_pose(Pose.create_from_pq(cup))
            self.beans.set_positions(self.pile(tray))

    def pile(self, tray: torch.Tensor) -> torch.Tensor:
        """Bean positions [b, N, 3]: a square lattice (spacing 2.1 radii) filling a `PILE_DEPTH` band (along y)
        round `PILE_Y` of the tray's floor layer by layer, far rows first, jittered by 0.05 radius (as
        `particles.pack_in_container`)."""
        r = self.bean_radius
        spacing = PILE_SPACING * r
        kx, ky = (int((half - PILE_CLEARANCE * r) // spacing) for half in (TRAY_INNER[0], PILE_DEPTH / 2))
        xy = np.stack(np.meshgrid(np.arange(-kx, kx + 1) * spacing, PILE_Y + np.arange(ky, -ky - 1, -1) * spacing), -1).reshape(-1, 2)
        layers = -(-self.bean_count // len(xy))
        z = np.repeat(TRAY_FLOOR + PILE_LIFT * r + spacing * np.arange(layers), len(xy))[:, None]
        pts = np.concatenate([np.tile(xy, (layers, 1)), z], axis=1)[: self.bean_count]
        out = torch.tensor(pts, dtype=torch.float32, device=tray.device).expand(len(tray), -1, 3)
        out = out + (torch.rand(out.shape, device=tray.device) - 0.5) * PILE_JITTER * r
        return out + tray[:, None]

    # ---- what the rule reads --------------------------------------------------------------------------
    def in_palm(self, positions: torch.Tensor | None = None) -> torch.Tensor:
        """Beans in the right hand's cupped palm (a box in its TCP frame), [B, N] (`positions`: as `in_cup`)."""
        positions = self.beans.positions() if positions is None else positions
        return particles.inside_box(positions, self.ee.tcp(SCOOPER), PALM_BOX_CENTRE, PALM_BOX_HALF)

    def in_tray(self, positions: torch.Tensor | None = None) -> torch.Tensor:
        """Beans over the tray's floor below its rim (its inner box), [B, N] (`positions`: as `in_cup`)."""
        half = (TRAY_INNER[0], TRAY_INNER[1], TRAY_WALL_HEIGHT / 2)
        centre = (0.0, 0.0, TRAY_FLOOR + TRAY_WALL_HEIGHT / 2)
        positions = self.beans.positions() if positions is None else positions
        return particles.inside_box(positions, self.tray.pose, centre, half)

    def cup_held_up(self) -> torch.Tensor:
        return self.ee.holds(self.cup, HOLDER) & (self.cup.pose.p[:, 2] >= self.cup_lift)

    def _update_memory(self):
        carried = self.memory["carried"] > 0.5
        scooping = ~self.ee.touches(self.tray, SCOOPER)
        positions = self.beans.positions()
        carried |= self.in_palm(positions) & ~self.in_tray(positions) & scooping[:, None]
        self.memory.store("carried", carried.float())
        self.memory.latch("cup_let_go", (self.in_cup(positions) & carried).any(dim=1) & ~self.cup_held_up())

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   cup_held=info["cup_held"])
        if "state" in self.obs_mode:
            obs.update(tray_pose=self.tray.pose.raw_pose, cup_pose=self.cup.pose.raw_pose,
                       beans_positions=self.beans.positions().flatten(1))
        return obs

    def evaluate(self):
        positions = self.beans.positions()
        delivery = self.delivery_metrics(positions)
        held = self.ee.holds(self.cup, HOLDER)
        held_up = held & (self.cup.pose.p[:, 2] >= self.cup_lift)
        let_go = self.memory["cup_let_go"]
        return {
            "success": (delivery["beans_delivered"] >= self.min_beans) & held_up & ~let_go,
            **delivery,
            "beans_in_palm": self.in_palm(positions).sum(dim=1),
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
