"""ScoopBeansWithSpoon (L2 deformable SG): scoop beans from a bowl with a spoon and tip them into a cup."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms import geometry
from maniladder_ms.deformables import particles
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects import containers
from maniladder_ms.objects.tabletop import place_at_rest
from maniladder_ms.objects.tools import SpoonShape, build_spoon

from .base import ScoopBeansTask

SPOON_DENSITY = 500.0  # kg/m^3 (a light wooden spoon)
SPOON_FRICTION = 2.0  # a grippy handle: the fingers' pads hold its pitch against the head's load
BOWL_DENSITY = 2400.0  # kg/m^3 (a heavy stoneware bowl: the spoon scrapes its floor and wall)


@register_task("ScoopBeansWithSpoon")
class ScoopBeansWithSpoonEnv(ScoopBeansTask, ManiLadderEnv):
    """**Task:** a bowl of beans, a cup and a spoon stand on the table. Grasp the spoon by its handle, scoop
    beans out of the bowl with its head, carry them level to the cup and tip them into it.

    **Randomisation:**
    - the bowl (inner radius 8 cm at the rim, 5 cm tall) stands at x in `bowl_x_range`, y in `bowl_y_range`,
      holding `bean_count` beans (granular spheres of radius `bean_radius`) packed from its floor with a small
      random jitter;
    - the cup (inner radius 4 cm, 9 cm tall) stands to the robot's left, x in `cup_x_range`, y in
      `cup_y_range`;
    - the spoon (a scoop: a flat head 5 x 4.4 cm inside, walled at the back and the sides, open at its
      bevelled front edge; a 10 cm handle 5 cm up on a riser behind it) lies level to the robot's right, its
      head's centre at x in `spoon_x_range`, y in `spoon_y_range`, pointing to +y (towards the bowl) turned by
      a uniform yaw in +-`spoon_max_yaw`.

    **Success:** at least `min_beans` beans lie inside the cup's inner volume (below its rim) that were
    carried there by the spoon: each of them rested in the spoon's head (`particles.inside_box` of the
    head's hollow, up to two bean radii over its rims) at some step at which the gripper held the spoon
    (`ee.holds`) and the bean was outside the bowl's inner volume (lifted out of the bowl in the held spoon;
    episode memory `carried`, one flag per bean); the gripper holds the spoon now and held it on every
    step since the first bean was carried (memory `let_go`).

    **Level 2:** against its Level 1 suite-mate PourBeansIntoBowl (2 stages, ~120 steps: grasp a cup and
    roll it over a bowl; the beans travel in a closed container and 80% of them may land anywhere in a bowl
    16 cm wide): 5 stages, repeated: one scoop carries 8-14 beans out of this pile, so the 10 needed take two
    scoops in ~480 of 550 steps (grasp a 1.6 cm handle; dig the head's edge, 25 degrees front down, into a
    pile ~2 beans deep; drag it 6-7 cm through the pile and up the far wall, the edge 1-3 mm over the floor
    and wall; turn the head about its edge and lift it out turning it to 25 degrees front up; carry it 0.2 m
    and tip it 60 degrees over an 8 cm cup; back to the bowl for the second scoop). The beans ride loose on an
    open tool: the head must stay front up from the scoop to the cup (at 10 degrees front up the beans on the
    bevelled front still roll off its open edge), and the tool is a lever (the head 9 cm out from the grasp)
    that the fingers hold only by friction: pressing its edge on the bowl's floor or tipping it turns it in
    the grip.
    """

    max_dense_reward = 6
    TASK_REGION = (-0.17, 0.13, -0.38, 0.24)
    PARAMS = ("bean_count", "bean_radius", "min_beans", "bowl_x_range", "bowl_y_range", "cup_x_range", "cup_y_range",
              "spoon_x_range", "spoon_y_range", "spoon_max_yaw")
    # piles of beans: PhysX contact caches are not env state (as the pour tasks)
    RESTORES_NEED_FRESH_SCENE = True
    spoon_shape = SpoonShape()
    bowl_shape = containers.bowl()
    cup_shape = containers.cup(radius=0.04, height=0.09)
    HANDLE_GRASP_BACK = 0.03  # the handle's grasp point this far behind the head's back rim (reward, solver)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.bowl = containers.build_container(self.scene, "bowl", self.bowl_shape, color=(0.35, 0.55, 0.75, 1),
                                               density=BOWL_DENSITY)
        self.cup = containers.build_container(self.scene, "cup", self.cup_shape, color=(0.9, 0.9, 0.92, 1))
        self.spoon = build_spoon(self.scene, "spoon", self.spoon_shape, SPOON_DENSITY, color=(0.75, 0.6, 0.4, 1),
                                 friction=SPOON_FRICTION)
        self.beans = particles.build_particles(self.scene, "beans", self.particle_config)
        self.memory.value("carried", self.bean_count)  # 1 where the bean was lifted out of the bowl in the held spoon
        self.memory.flag("let_go")  # the spoon was not held at a step after the first bean was carried

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            bowl = torch.stack([uniform(b, self.bowl_x_range), uniform(b, self.bowl_y_range), torch.zeros(b)], dim=1)
            cup = torch.stack([uniform(b, self.cup_x_range), uniform(b, self.cup_y_range), torch.zeros(b)], dim=1)
            spoon = torch.stack([uniform(b, self.spoon_x_range), uniform(b, self.spoon_y_range), torch.zeros(b)],
                                dim=1)
            yaw = np.pi / 2 + uniform_deg(b, (-self.spoon_max_yaw, self.spoon_max_yaw))
            self.bowl.set_pose(Pose.create_from_pq(bowl))
            self.cup.set_pose(Pose.create_from_pq(cup))
            place_at_rest(self.spoon, Pose.create_from_pq(spoon, yaw_quat(yaw)))
            particles.fill_upright(self.beans, self.bowl_shape, bowl)

    # ---- what the rule reads --------------------------------------------------------------------------
    def in_spoon(self) -> torch.Tensor:
        """Beans resting in the spoon's head (its hollow, up to two bean radii over the rims), [B, N]."""
        centre, half = self.spoon_shape.bowl_box(2 * self.bean_radius)
        return particles.inside_box(self.beans.positions(), self.spoon.pose, centre, half)

    def in_bowl(self) -> torch.Tensor:
        return self.bowl_shape.inside(self.beans.positions(), self.bowl.pose)

    def _update_memory(self):
        held = self.ee.holds(self.spoon)
        carried = self.memory["carried"] > 0.5
        carried |= self.in_spoon() & ~self.in_bowl() & held[:, None]
        self.memory.store("carried", carried.float())
        self.memory.latch("let_go", carried.any(dim=1) & ~held)

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["spoon_grasped"])
        if "state" in self.obs_mode:
            obs.update(spoon_pose=self.spoon.pose.raw_pose, bowl_pose=self.bowl.pose.raw_pose,
                       cup_pose=self.cup.pose.raw_pose, beans_positions=self.beans.positions().flatten(1))
        return obs

    def evaluate(self):
        held = self.ee.holds(self.spoon)
        let_go = self.memory["let_go"]
        delivery = self.delivery_metrics()
        return {
            "success": (delivery["beans_delivered"] >= self.min_beans) & held & ~let_go,
            **delivery,
            "beans_in_spoon": self.in_spoon().sum(dim=1),
            "spoon_grasped": held,
            "let_go": let_go,
            "spoon_lifted": self.spoon.pose.p[:, 2] > 0.03,
            "spoon_tilt": geometry.tilt(self.spoon),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the handle, grasp; beans in the head; carry over the cup; beans delivered
        grasp = self.spoon.pose * Pose.create_from_pq(torch.tensor([[self.spoon_shape.back_x - self.HANDLE_GRASP_BACK, 0.0,
                                                                     self.spoon_shape.handle_z]], device=self.device))
        reward = 1 - torch.tanh(5 * torch.linalg.norm(grasp.p - self.ee.tcp().p, dim=1))
        held = info["spoon_grasped"].float()
        reward += held
        loaded = (info["beans_in_spoon"].float() / self.min_beans).clamp(0, 1) * held
        reward += loaded
        to_cup = torch.linalg.norm((self.spoon.pose.p - self.cup.pose.p)[:, :2], dim=1)
        reward += loaded * info["spoon_lifted"] * (1 - torch.tanh(5 * to_cup))
        reward += 2 * (info["beans_delivered"].float() / self.min_beans).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
