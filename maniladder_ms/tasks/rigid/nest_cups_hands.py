"""NestCupsHands (L3 rigid DX): two LEAP hands nest three tapered cups of decreasing size into one another."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
import trimesh

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.layout import uniform
from maniladder_ms.objects import containers
from maniladder_ms.objects.tabletop import place_at_rest

# The three cups: tapered open shells (`containers.glass` profiles; inner radii at the inner floor and at the rim),
# WALL thick, FLOOR thick at the bottom, CUP_HEIGHT tall, each wall leaning out by TAPER (radius per height). Each
# cup's outer wall stands NEST_CLEARANCE inside the next larger cup's inner wall when it rests on that cup's floor,
# its rim FLOOR (= the rim gap of a seated cup, as the heights are equal) above the larger cup's rim. The taper
# makes a cup dropped with its bottom inside the next cup's mouth slide in: at the mouth the gap is the clearance
# plus the taper over the cup's height (~1 cm) instead of NEST_CLEARANCE.
WALL, FLOOR, CUP_HEIGHT = 0.003, 0.004, 0.09
TAPER = 0.078
NEST_CLEARANCE = 0.003
LARGE_BOTTOM_RADIUS = 0.036  # inner radius at the large cup's floor (its rim: 4.3 cm inner, 4.6 cm outer)
# ceramic-like cups (large ~0.18 kg, middle ~0.15 kg, small ~0.12 kg), friction as PlaceMugOnCoasterHand's mug: as
# plastic cups (density 1000, friction 0.6) the closing LEAP hands pushed them 2-7 cm over the table and they
# tilted 20-30 degrees in the grip (seed 103)
CUP_DENSITY = 2000.0
CUP_FRICTION = 1.0
# contact offset of the cups' shapes: below NEST_CLEARANCE, so seated cups' walls (3 mm apart, 24 sector hulls
# each) do not all generate contacts with each other (at the vessels' 5 mm a nested pair stepped
# ~4x slower than apart)
CUP_CONTACT_OFFSET = 0.001
CUP_COLORS = {"large": (0.85, 0.3, 0.25, 1), "middle": (0.95, 0.75, 0.2, 1), "small": (0.25, 0.5, 0.85, 1)}
NAMES = ("large", "middle", "small")


def quat_tilt(q: torch.Tensor) -> torch.Tensor:
    """(n,) angle (rad) between the z axis turned by the wxyz quaternions `q` (n, 4) and the world's
    (`geometry.tilt` of a pose already read)."""
    return torch.arccos((1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2)).clamp(-1, 1))


def unrotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """(n, 3) vectors `v` (n, 3) turned by the inverse of the unit wxyz quaternions `q` (n, 4) (world to body
    frame; v + w t + u x t with t = 2 u x v, u the negated vector part)."""
    w, u = q[:, :1], -q[:, 1:]
    t = 2 * torch.linalg.cross(u, v)
    return v + w * t + torch.linalg.cross(u, t)


def cup_shapes() -> dict[str, containers.ContainerShape]:
    """The three cups' shapes (`containers.glass`), largest first: each one's inner floor radius is the larger one's
    less a wall and NEST_CLEARANCE (plus the taper over a floor: the smaller cup's outer wall starts leaning one
    floor higher)."""
    shapes, bottom = {}, LARGE_BOTTOM_RADIUS
    for name in NAMES:
        top = bottom + TAPER * (CUP_HEIGHT - FLOOR)
        shapes[name] = containers.glass(bottom_radius=bottom, top_radius=top, height=CUP_HEIGHT, wall=WALL, floor=FLOOR)
        bottom = bottom - WALL - NEST_CLEARANCE + TAPER * FLOOR
    return shapes


def cup_hulls(shape: containers.ContainerShape) -> list[np.ndarray]:
    """The cup's convex pieces: its wall as `containers.shell_hulls`' SHELL_SECTIONS sector hulls and its floor as
    ONE hull, the SHELL_SECTIONS-gon disc that `shell_hulls`' floor wedges tile (the same solid: the wedges' union is
    convex). One floor shape instead of 24 on the table and on the next cup's floor: `maniladder bench` (state, random
    actions) 0.21x PickCube-v1 with the wedges, 0.29x with the disc (before `evaluate`'s own savings)."""
    walls = containers.shell_hulls(replace(shape, floor=0.0))
    angles = np.linspace(0.0, 2 * np.pi, containers.SHELL_SECTIONS, endpoint=False)
    r = shape.inner[0][1] + shape.wall
    disc = np.array([[r * np.cos(a), r * np.sin(a), z] for z in (0.0, shape.floor) for a in angles])
    return walls + [disc]


def cup_files(shape: containers.ContainerShape) -> tuple[Path, Path, list[Path]]:
    """(visual mesh, floor disc, wall piece files) of `cup_hulls(shape)`, written once into the user cache."""
    mesh = trimesh.creation.revolve(shape.profile(), sections=containers.SECTIONS)
    visual, files = containers.cached_pieces(mesh, cup_hulls(shape), "cup",
                                             ["sector walls, one floor disc", containers.SHELL_SECTIONS])
    return visual, files[-1], files[:-1]


@register_task("NestCupsHands")
class NestCupsHandsEnv(ManiLadderEnv):
    """**Task:** three open cups of decreasing size stand upright on the table: the large one in front of the robot,
    between the arms, the middle one on the left (+y), the small one on the right (-y), 11-19 cm to either side of
    the large one. The two LEAP hands nest them: the middle cup goes into the large one and the small cup into the
    middle one, and both hands let go. The solver's way: the left hand carries the middle cup into the large one,
    then the right hand the small cup into the middle one (each cup stands on its own hand's side: the right arm
    reaching top-down across to the left side flipped its IK branch).

    **Randomisation:** the cups (tapered ceramic-like shells, all 9 cm tall, 3 mm walls: rims 4.6 / 4.0 / 3.4 cm outer
    radius; `cup_shapes`: each seated cup's outer wall 3 mm (`NEST_CLEARANCE`) inside the next one's inner wall,
    its rim 4 mm above the next one's) stand upright with their bottom centres uniform in x in `large_x_range`,
    `middle_x_range`, `small_x_range` and y in `large_y_range`, `middle_y_range`, `small_y_range` (round cups:
    their yaw is not seen).

    **Success:** for each of the two smaller cups, in the frame of the next larger cup (its container): its axis
    (bottom centre) is within `max_axis_offset` of the container's axis horizontally, its bottom lies inside the
    container (above the container's inner floor less `seat_tol`, below its rim), its rim is within
    `max_rim_gap` of the container's rim in height (above or below), and it stands within `max_tilt` of upright;
    the large cup stands on the table (its bottom at most `seat_tol` above it) within `max_tilt` of upright; no
    part of either hand touches any cup (`ee.touches`: released); and every cup moves slower than `rest_speed`
    (the nest at rest). A cup balanced across a rim, wedged halfway in, lying on its side or still held fails.

    **Level 3:** (against Level 2's PlaceMugOnCoasterHand, one hand setting one mug on an 11 cm coaster within
    2 cm, and CarryBoxToShelfHands, two hands on one box) two placements in sequence by two hands, each hand
    carrying its own cup (the middle cup carried with the small one in it), into a mouth that leaves 3 mm
    between the nested walls (about 1 cm at the mouth through the taper): the carried cup's bottom must enter a
    mouth that is 0.7-1 cm wider in radius than it, the rim pinned within `max_axis_offset` of the container's
    axis, and the fingers holding it around its outside cannot go in with it, so each cup is let go above the
    container and falls the last 4-5 cm along the walls; the scripted episodes take ~400 control steps.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 10
    TASK_REGION = (-0.2, 0.0, -0.25, 0.25)
    PARAMS = ("max_axis_offset", "max_rim_gap", "max_tilt", "seat_tol", "rest_speed",
              "large_x_range", "large_y_range", "middle_x_range", "middle_y_range", "small_x_range", "small_y_range")
    shapes = cup_shapes()

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cups = {}
        for name in NAMES:
            visual, floor, walls = cup_files(self.shapes[name])
            builder, _, _ = containers.builder_from_files(self.scene, visual, walls + [floor], CUP_COLORS[name],
                                                          CUP_DENSITY, CUP_FRICTION)
            self.cups[name] = containers.build_resting(builder, f"{name}_cup")
            containers.set_contact_offset(self.cups[name], CUP_CONTACT_OFFSET)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            for name in NAMES:
                x, y = getattr(self, f"{name}_x_range"), getattr(self, f"{name}_y_range")
                p = torch.stack([uniform(b, x), uniform(b, y), torch.zeros(b)], dim=1)
                place_at_rest(self.cups[name], Pose.create_from_pq(p))

    # ---- what the rule reads --------------------------------------------------------------------------
    def nested(self, inner: str, outer: str, poses: dict[str, tuple[torch.Tensor, torch.Tensor]] = None
               ) -> dict[str, torch.Tensor]:
        """The parts of `inner` resting nested in `outer` (the cups' names), each (num_envs,); `poses`: the cups'
        (p, q) by name, read once per `evaluate`."""
        poses = poses or self.cup_poses()
        (p_in, q_in), (p_out, q_out) = poses[inner], poses[outer]
        local = unrotate(q_out, p_in - p_out)  # the inner cup's bottom centre in the container's frame
        shape_in, shape_out = self.shapes[inner], self.shapes[outer]
        offset = torch.linalg.norm(local[:, :2], dim=1)
        rim_gap = local[:, 2] + shape_in.height - shape_out.height
        inside = (local[:, 2] >= shape_out.floor - self.seat_tol) & (local[:, 2] <= shape_out.height)
        upright = torch.rad2deg(quat_tilt(q_in)) <= self.max_tilt
        return {"axis_offset": offset, "rim_gap": rim_gap, "inside": inside,
                "ok": (offset <= self.max_axis_offset) & inside & (rim_gap.abs() <= self.max_rim_gap) & upright}

    def cup_poses(self) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
        """Each cup's (p, q), (num_envs, 3) and (num_envs, 4), by name."""
        return {name: (raw[:, :3], raw[:, 3:]) for name, raw in ((n, c.pose.raw_pose) for n, c in self.cups.items())}

    def evaluate(self):
        poses = self.cup_poses()
        middle_in_large, small_in_middle = self.nested("middle", "large", poses), self.nested("small", "middle", poses)
        large_p, large_q = poses["large"]
        large_ok = (large_p[:, 2] <= self.seat_tol) & (torch.rad2deg(quat_tilt(large_q)) <= self.max_tilt)
        cups = list(self.cups.values())
        touched = self.ee.touches(cups)
        # a LEAP hand holding a cup presses on it (`holds` needs a link's force over LEAP_CONTACT_FORCE, `touches`
        # over TOUCH_FORCE, both 0.05 N, from the same contacts): with no hand touching any cup neither holds one,
        # and the two per-link contact queries of `holds` (half an evaluate under random actions) are skipped
        if bool(touched.any()):
            small_held, middle_held = self.ee.holds(self.cups["small"]), self.ee.holds(self.cups["middle"])
        else:
            small_held, middle_held = torch.zeros_like(touched), torch.zeros_like(touched)
        speed = torch.stack([torch.linalg.norm(c.linear_velocity, dim=1) for c in cups], dim=1).max(dim=1).values
        at_rest = speed < self.rest_speed
        return {
            "success": middle_in_large["ok"] & small_in_middle["ok"] & large_ok & ~touched & at_rest,
            "middle_in_large": middle_in_large["ok"],
            "small_in_middle": small_in_middle["ok"],
            "middle_offset": middle_in_large["axis_offset"],
            "small_offset": small_in_middle["axis_offset"],
            "middle_rim_gap": middle_in_large["rim_gap"],
            "small_rim_gap": small_in_middle["rim_gap"],
            "large_upright": large_ok,
            "small_held": small_held,
            "middle_held": middle_held,
            "cups_touched": touched,
            "at_rest": at_rest,
        }

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose)
        if "state" in self.obs_mode:
            for name, cup in self.cups.items():
                obs[f"{name}_cup_pose"] = cup.pose.raw_pose
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # each smaller cup: reached, held, over its container (bottom centre to the container's mouth), nested;
        # then both nested and let go
        small, middle, large = (self.cups[n].pose.p for n in NAMES[::-1])
        mouth = torch.tensor([0.0, 0.0, CUP_HEIGHT], device=self.device)
        reward = torch.zeros(self.num_envs, device=self.device)
        for cup, container, side, held, done in ((small, middle, "right", info["small_held"], info["small_in_middle"]),
                                                 (middle, large, "left", info["middle_held"], info["middle_in_large"])):
            reach = 1 - torch.tanh(5 * torch.linalg.norm(cup + mouth / 2 - self.ee.tcp(side).p, dim=1))
            over = 1 - torch.tanh(5 * torch.linalg.norm(cup - container - mouth, dim=1))
            stage = reach + held.float() + held.float() * over
            reward += torch.where(done, torch.full_like(reward, 4.0), stage)
        both = info["small_in_middle"] & info["middle_in_large"]
        reward += both.float() * (1 + (~info["cups_touched"]).float())
        reward[info["success"]] = self.max_dense_reward
        return reward
