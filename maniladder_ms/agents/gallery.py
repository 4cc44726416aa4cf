"""`ManiLadder-AgentGallery-v1`: any ManiLadder agent in the empty ladder scene, optionally with one
test object in reach of an arm.

It is what `maniladder render --robot` shows, what `maniladder bench --robot` times, and where the agent
tests lift and hold objects. Test objects:
- `cube`: 5 cm wooden-density cube (125 g), yawed within +-45 degrees, position jittered +-3 cm;
- `cylinder`: 300 g cylinder, 6 cm diameter, 12 cm tall, standing (a can to hold from the top),
  position jittered +-2 cm.
Not a task: no success rule, no reward (reward mode "none").
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
from maniladder_ms.objects.tabletop import build_upright_cylinder

from . import AGENT_UIDS

CUBE_HALF = 0.025
CYLINDER_RADIUS, CYLINDER_HALF_LENGTH, CYLINDER_MASS = 0.03, 0.06, 0.3
TEST_OBJECTS = ("cube", "cylinder")
# world xy in easy reach of each agent's (left) arm: 0.45 m ahead of the arm base (0.5 m for the
# dual LEAP arms, whose long hands tilt when the arm folds to reach closer)
DEFAULT_OBJECT_XY = {"ml_panda": (-0.15, 0.0), "ml_panda_leap": (-0.15, 0.0), "ml_dual_panda": (-0.15, 0.3),
                     "ml_dual_panda_leap": (-0.1, 0.3), "ml_tidybot": (-0.45, 0.0)}


@register_env("ManiLadder-AgentGallery-v1", max_episode_steps=200)
class AgentGalleryEnv(ManiLadderEnv):
    """An agent in the empty ladder scene; `test_object` ("cube" / "cylinder") at `object_xy` (world,
    default: ahead of the agent's (left) arm)."""

    SUPPORTED_ROBOTS = list(AGENT_UIDS)
    SUPPORTED_REWARD_MODES = ("none",)

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
            volume = np.pi * CYLINDER_RADIUS**2 * 2 * CYLINDER_HALF_LENGTH
            self.object = build_upright_cylinder(self.scene, "cylinder", CYLINDER_RADIUS, CYLINDER_HALF_LENGTH,
                                                 CYLINDER_MASS / volume, (0.2, 0.45, 0.8, 1))

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
