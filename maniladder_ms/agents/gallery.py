"""`ManiLadder-AgentGallery-v1`: any ManiLadder agent in the empty ladder scene, optionally with one
test object in reach of an arm.

It is what `maniladder render --robot` shows, what `maniladder bench --robot` times, and where the agent
tests lift and hold objects. Test objects:
- `cube`: 5 cm wooden-density cube (125 g), yawed within +-45 degrees, position jittered +-3 cm;
- `cylinder`: 300 g cylinder, 6 cm diameter, 12 cm tall, standing (a can to hold from the top),
  position jittered +-2 cm.
No success rule: the env only measures nothing and rewards nothing.
"""

from __future__ import annotations

from typing import Optional

import numpy as np
import sapien
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.registration import register_env
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs.base import ManiLadderEnv
from maniladder_ms.geometry import yaw_quat

from . import AGENT_UIDS

CUBE_HALF = 0.025
CYLINDER_RADIUS, CYLINDER_HALF_LENGTH, CYLINDER_MASS = 0.03, 0.06, 0.3
TEST_OBJECTS = ("cube", "cylinder")
# world xy in easy reach of each agent's (left) arm: 0.45 m ahead of the arm base (0.5 m for the
# dual LEAP arms, whose long hands tilt when the arm folds to reach closer)
DEFAULT_OBJECT_XY = {"ml_panda": (-0.15, 0.0), "ml_panda_leap": (-0.15, 0.0), "ml_dual_panda": (-0.15, 0.3),
                     "ml_dual_panda_leap": (-0.1, 0.3), "ml_tidybot": (-0.45, 0.0)}


def _build_cylinder(scene, name: str):
    builder = scene.create_actor_builder()
    volume = np.pi * CYLINDER_RADIUS**2 * 2 * CYLINDER_HALF_LENGTH
    # SAPIEN cylinders lie along their local x axis: turn it upright
    upright = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
    builder.add_cylinder_collision(upright, radius=CYLINDER_RADIUS, half_length=CYLINDER_HALF_LENGTH,
                                   density=CYLINDER_MASS / volume)
    material = sapien.render.RenderMaterial(base_color=[0.2, 0.45, 0.8, 1], roughness=0.5)
    builder.add_cylinder_visual(upright, radius=CYLINDER_RADIUS, half_length=CYLINDER_HALF_LENGTH, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, CYLINDER_HALF_LENGTH])
    return builder.build(name=name)


@register_env("ManiLadder-AgentGallery-v1", max_episode_steps=200)
class AgentGalleryEnv(ManiLadderEnv):
    """An agent in the empty ladder scene; `test_object` ("cube" / "cylinder") at `object_xy` (world,
    default: ahead of the agent's (left) arm)."""

    SUPPORTED_ROBOTS = list(AGENT_UIDS)

    def __init__(self, *args, test_object: Optional[str] = None, object_xy: Optional[tuple[float, float]] = None,
                 **kwargs):
        if test_object not in (None, *TEST_OBJECTS):
            raise ValueError(f"test_object must be one of {TEST_OBJECTS} or None, not {test_object!r}")
        self.test_object = test_object
        self.object_xy = object_xy
        super().__init__(*args, task_id=None, **kwargs)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        if self.test_object == "cube":
            self.object = actors.build_cube(self.scene, half_size=CUBE_HALF, color=[0.8, 0.2, 0.2, 1], name="cube",
                                            initial_pose=sapien.Pose(p=[0, 0, CUBE_HALF]))
        elif self.test_object == "cylinder":
            self.object = _build_cylinder(self.scene, "cylinder")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        if self.test_object is None:
            return
        b = len(env_idx)
        xy = torch.tensor(self.object_xy or DEFAULT_OBJECT_XY[self.agent.uid], dtype=torch.float32)
        if self.test_object == "cube":
            xy = xy + (torch.rand(b, 2) * 2 - 1) * 0.03
            z, yaw = CUBE_HALF, (torch.rand(b) * 2 - 1) * np.pi / 4
        else:
            xy = xy + (torch.rand(b, 2) * 2 - 1) * 0.02
            z, yaw = CYLINDER_HALF_LENGTH, torch.zeros(b)
        p = torch.cat([xy.expand(b, 2), torch.full((b, 1), z)], dim=1)
        self.object.set_pose(Pose.create_from_pq(p, yaw_quat(yaw)))

    def evaluate(self):
        return {}

    def _get_obs_extra(self, info):
        return {}

    def compute_dense_reward(self, obs, action, info):
        return torch.zeros(self.num_envs, device=self.device)

    def compute_normalized_dense_reward(self, obs, action, info):
        return self.compute_dense_reward(obs, action, info)
