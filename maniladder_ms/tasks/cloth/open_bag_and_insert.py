"""OpenBagAndInsert (L3 deformable DG): one gripper holds a flat bag's mouth open, the other puts a cube inside."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import bag, cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform, uniform_deg
from maniladder_ms.tasks.cloth.base import SIDES

ROWS, COLS = 5, 10  # the bag: 5 rows deep (10 cm from bottom to mouth), 10 columns wide (22.5 cm), 100 particles
MOUTH_YAW = np.pi  # the bag's local +x (its mouth) turned to -x: the mouth faces the robot
HOLDER, INSERTER = "left", "right"  # the arm holding the mouth open, the arm putting the cube in


@register_task("OpenBagAndInsert")
class OpenBagAndInsertEnv(ManiLadderEnv):
    """**Task:** a bag lies flat on its back on the table, its mouth towards the robot, a cube beside it on the
    right. The left gripper takes the bag's front rim and lifts it, holding the mouth open; the right gripper
    picks up the cube and puts it into the bag through the mouth, and lets go of it.

    **Randomisation:** the bag (`bag.pouch(5, 10)`: two panels of 5 x 10 particles 2.5 cm apart, radius 8 mm,
    sewn along both sides and the bottom, 10 cm deep and 22.5 cm wide, 100 particles; closed as it lies, the
    front panel resting on the back one) is centred at x uniform in `bag_x_range`, y uniform in `bag_y_range`,
    its mouth towards the robot (-x) turned by a yaw uniform in +-`bag_max_yaw`; the cube (half size
    `cube_half`) at x uniform in `cube_x_range`, y uniform in `cube_y_range`, its yaw uniform in
    `cube_yaw_range`.

    **Success:** the cube is inside the bag (`bag.inside`): along the back panel between its side seams, between
    its bottom and `min_depth` short of its mouth; over the back panel, its centre at most `max_cube_height` from
    it; not on top of the front panel (no front particle near it lies below it); the bag lies on its back: the
    back panel faces up (its normal towards the front panel points up) with its mean particle height at most
    `max_bag_height`; the cube went in held open and by a grasp: at a step when it was first inside, the left
    gripper held a front rim particle (`ee.holds`) and the right gripper had held the cube before (episode memory
    `entered_held_open`, `cube_grasped`); and the right gripper has let go of the cube (`ee.touches`).

    **Level 3:** its Level-2 deformable suite-mates carry one cloth piece (FoldTowelInHalf: half a towel over,
    2 carries, T 27.0). Here the two arms work on two objects at once: one holds the deformable open by a single
    pinched rim particle (8 mm) while the other slides a rigid cube (3 cm) through the arch that hold makes (about
    7 cm high beside the held particle), its hand kept outside the mouth, at least 3 cm past the mouth, and lets go
    before the front panel falls back. The 20 demos take 240 steps on average (184-376) of a 500-step horizon, 5
    stages (take the rim, hold it open, pick the cube, slide it in, let go): T = 10 log10 240 + 5 = 28.8.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 8
    TASK_REGION = (-0.35, 0.1, -0.3, 0.2)  # the bag's and the cube's ranges plus the bag's half diagonal
    cloth_config = cloth.ClothConfig(color=(0.85, 0.75, 0.45, 1), border_color=(0.45, 0.3, 0.15, 1))
    # particles resting on the table and on each other: PhysX contact caches are not state
    RESTORES_NEED_FRESH_SCENE = True
    PARAMS = ("min_depth", "max_cube_height", "max_bag_height", "cube_half", "bag_x_range", "bag_y_range",
              "bag_max_yaw", "cube_x_range", "cube_y_range", "cube_yaw_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = bag.pouch(ROWS, COLS, self.cloth_config.spacing, self.cloth_config.radius)
        self.bag = cloth.build_cloth(self.scene, "bag", layout, self.cloth_config)
        self.front_rim = [self.bag.spheres[i] for i in layout.named["front_rim"]]
        self.cube = actors.build_cube(self.scene, half_size=self.cube_half, color=(0.85, 0.2, 0.15, 1), name="cube",
                                      initial_pose=Pose.create_from_pq([0, -0.2, self.cube_half]).sp)
        self.memory.flag("cube_grasped")  # the right gripper has held the cube
        self.memory.flag("was_inside")  # the cube has been inside the bag
        self.memory.flag("entered_held_open")  # when first inside, the left held the front rim, the cube grasped before

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centre = torch.stack([uniform(b, self.bag_x_range), uniform(b, self.bag_y_range),
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            self.bag.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(MOUTH_YAW + symmetric_deg(b, self.bag_max_yaw))))
            cube = torch.stack([uniform(b, self.cube_x_range), uniform(b, self.cube_y_range),
                                torch.full((b,), self.cube_half)], dim=1)
            self.cube.set_pose(Pose.create_from_pq(cube, yaw_quat(uniform_deg(b, self.cube_yaw_range))))

    def _cube_inside(self) -> torch.Tensor:
        return bag.inside(self.bag.positions(), self.bag.layout, self.cube.pose.p, self.cloth_config.spacing,
                          self.min_depth, self.max_cube_height)

    def _update_memory(self):
        self.memory.latch("cube_grasped", self.ee.holds(self.cube, INSERTER))
        entering = self._cube_inside() & ~self.memory["was_inside"]
        if entering.any():
            held_open = self.ee.holds(self.front_rim, HOLDER) & self.memory["cube_grasped"]
            self.memory.latch("entered_held_open", entering & held_open)
            self.memory.latch("was_inside", entering)

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        obs.update(rim_grasped=info["rim_grasped"], cube_grasped=info["cube_grasped"])
        if "state" in self.obs_mode:
            obs.update(bag_points=self.bag.positions().flatten(1), cube_pose=self.cube.pose.raw_pose)
        return obs

    def evaluate(self):
        points = self.bag.positions()
        frame = bag.bag_frame(points, self.bag.layout)
        back_height = points[:, self.bag.layout.named["back"], 2].mean(dim=1)
        bag_on_back = (frame["w"][:, 2] > 0) & (back_height <= self.max_bag_height)
        cube_inside = self._cube_inside()
        released = ~self.ee.touches(self.cube, INSERTER)
        entered = self.memory["entered_held_open"]
        return dict(success=cube_inside & bag_on_back & entered & released, cube_inside=cube_inside,
                    bag_on_back=bag_on_back, entered_held_open=entered, cube_released=released,
                    rim_grasped=self.ee.holds(self.front_rim, HOLDER), cube_grasped=self.ee.holds(self.cube, INSERTER))

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        rim = torch.stack([s.pose.p for s in self.front_rim], dim=1)  # [B, cols, 3]
        rim_reach = torch.linalg.norm(rim - self.ee.tcp(HOLDER).p[:, None], dim=-1).amin(dim=1)
        cube_p = self.cube.pose.p
        cube_reach = torch.linalg.norm(cube_p - self.ee.tcp(INSERTER).p, dim=1)
        frame = bag.bag_frame(self.bag.positions(), self.bag.layout)
        mouth = frame["centre"] + frame["u"] * frame["mouth"][:, None]
        to_mouth = torch.linalg.norm(cube_p - mouth, dim=1)
        rim_grasped, cube_grasped = info["rim_grasped"].float(), info["cube_grasped"].float()
        # stages: the left reaches and takes the rim; the right reaches and takes the cube; the cube carried to the
        # mouth while it is held open; inside; let go
        reward = (1 - torch.tanh(5 * rim_reach)) + rim_grasped
        reward += (1 - torch.tanh(5 * cube_reach)) + cube_grasped
        reward += (1 - torch.tanh(5 * to_mouth)) * cube_grasped * rim_grasped
        reward += 2 * (info["cube_inside"] & info["entered_held_open"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
