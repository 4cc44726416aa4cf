"""CableIntoClipHand (L2 deformable SX): pinch a cable with the LEAP hand, lay it over a U-shaped clip and press
it into the clip's slot."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.tabletop import Channel
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.base import RopeTask

CLIP_WALL = 0.008  # thickness of each of the clip's two walls
CLIP_FLOOR = 0.004  # the clip's base plate: the slot's floor lies this high above the table
CLIP_GAP = (0.09, 0.12)  # metres from the cable's middle capsule to the clip's axis, sideways: the open scissor
# fingertips reach ~6 cm to each side of the pinched capsule, and must come down clear of the clip
CLIP_TURN = 20  # degrees: the clip's axis lies within this of the middle capsule's heading
ROPE_WAVE = 0.1  # rad: amplitude bound of the cable's in-plane S (`rope.wavy_turns`)
CLIP_COLOR, CLIP_FLOOR_COLOR = (0.15, 0.35, 0.75, 1), (0.1, 0.2, 0.45, 1)


@register_task("CableIntoClipHand")
class CableIntoClipHandEnv(RopeTask, ManiLadderEnv):
    """**Task:** a cable lies on the table and beside it a short U-shaped clip is fixed to the table; pinch the
    cable with the LEAP hand, lift it over the clip, lay it along the clip's slot, let go and press it down into
    the slot with the fingers, then take the hand away.

    **Randomisation:** the cable (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter, both ends free)
    lies flat in a gentle S (the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 +
    phase), amp uniform in [0, 0.1] rad, phase uniform), the mean of its capsule centres at x uniform in
    [-0.15, -0.05], y uniform in [-0.08, 0.08], its first capsule's heading uniform in [0, 2 pi); the clip (a
    4 mm base plate and two 8 mm thick walls, `slot_width` apart, `clip_depth` high above the plate and
    `clip_length` long, open at both ends) has its centre on the table a distance uniform in [0.09, 0.12] m to
    the left or the right (equally likely) of the cable's middle capsule (index 10), at right angles to that
    capsule's heading, and its axis within +-20 degrees (uniform) of that heading.

    **Success:** at least `min_segments` of the cable's capsules lie inside the clip's slot (`metrics.
    inside_channel_fraction` times the capsule count: the capsule's centre between the walls, at most half of
    `slot_width` from the slot's axis sideways, between the clip's ends (`clip_length` long), and below the walls' top, `clip_depth`
    above the slot's floor); the hand does not touch the cable (`ee.touches`: let go); and earlier in the episode
    the hand touched the cable while at least `min_segments` of its capsules lay in the slot (episode memory
    `pressed`: the cable was pressed home by the hand, not left to fall in).

    `is_grasped` (reward and observation only): the hand holds (`ee.holds`) the cable's middle capsule or one
    of its two neighbours.

    **Level 2:** (against Level 1's LiftRopeHand on the same cable and hand: 2 stages, pinch the middle capsule
    and lift half the rope 10 cm, no placement tolerance, ~90 steps) 5 stages (pinch; lift 3 cm and carry the
    cable 9-12 cm sideways; turn it up to 20 degrees onto the clip's axis and lower it over the slot; let go; press
    it home and withdraw) in ~200 steps. The slot is 19 mm wide for the 16 mm cable: 1.5 mm to spare on each
    side, so over the clip's 6 cm the cable must lie within ~3 degrees of its axis; the walls are only 12 mm
    high, the cable's centre must end below their top (a capsule resting on a wall top lies 8 mm above it), and
    the spread fingertips that pinch the cable are wider than the slot, so it is let go just above the walls and
    pressed in with the fingers closed; 3 capsules, the whole of the clip's length, must end inside.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 6
    # cable and clip: the cable's middle within x [-0.15, -0.05], |y| <= 0.08, its tips up to 20 cm further,
    # the clip up to 12 cm (and its 3.5 cm half length) beyond the middle
    TASK_REGION = (-0.4, 0.2, -0.35, 0.35)
    PARAMS = ("min_segments", "slot_width", "clip_depth", "clip_length")

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the cable (RopeTask)
        self.clip = Channel(self.scene, "clip", self.slot_width, self.clip_depth, self.clip_length, CLIP_WALL,
                            CLIP_FLOOR, CLIP_COLOR, CLIP_FLOOR_COLOR)
        self.memory.flag("pressed")  # the hand touched the cable while it lay in the slot

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            turns = rope.wavy_turns(b, self.rope_config.segments, ROPE_WAVE)
            heading = torch.rand(b) * 2 * np.pi
            middle = torch.stack([torch.rand(b) * 0.1 - 0.15, torch.rand(b) * 0.16 - 0.08], dim=1)
            centres = self.rope.lay_flat(middle, heading, turns)
            k = self.grasp_segment
            along = centres[:, k + 1, :2] - centres[:, k - 1, :2]
            yaw = torch.atan2(along[:, 1], along[:, 0])
            side = torch.where(torch.rand(b) < 0.5, 1.0, -1.0)
            gap = CLIP_GAP[0] + torch.rand(b) * (CLIP_GAP[1] - CLIP_GAP[0])
            normal = torch.stack([-torch.sin(yaw), torch.cos(yaw)], dim=1)
            xy = centres[:, k, :2] + (side * gap)[:, None] * normal
            axis = yaw + (torch.rand(b) * 2 - 1) * np.deg2rad(CLIP_TURN)
            self.clip.set_pose(Pose.create_from_pq(torch.cat([xy, torch.zeros(b, 1)], dim=1), yaw_quat(axis)))

    def inside_count(self) -> torch.Tensor:
        """Number of the cable's capsules inside the clip's slot, [B] (float)."""
        return self.clip.inside_fraction(self.rope.points()[:, 1:-1]) * self.rope_config.segments

    def _update_memory(self):
        seated = self.inside_count() >= self.min_segments
        self.memory.latch("pressed", seated & self.ee.touches(self.rope.links))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), clip_pose=self.clip.pose.raw_pose,
                       inside_count=info["inside_count"],
                       tcp_to_grasp_segment=self.rope.links[self.grasp_segment].pose.p - self.ee.tcp().p)
        return obs

    def evaluate(self):
        count = self.inside_count()
        seated = count >= self.min_segments
        touched = self.ee.touches(self.rope.links)
        k = self.grasp_segment
        pressed = self.memory["pressed"]
        # the middle capsule's distance from the slot's axis line (top-down), for the reward
        off_axis = self.clip.off_axis(self.rope.links[k].pose.p[:, None])[:, 0]
        return {
            "success": seated & ~touched & pressed,
            "inside_count": count,
            "seated": seated,
            "pressed": pressed,
            "touching_cable": touched,
            "off_axis": off_axis,
            "is_grasped": self.ee.holds(self.rope.links[k - 1:k + 2]),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        target = self.rope.links[self.grasp_segment].pose.p
        reach = 1 - torch.tanh(5 * torch.linalg.norm(target - self.ee.tcp().p, dim=1))
        near_axis = 1 - torch.tanh(10 * info["off_axis"])
        inside = (info["inside_count"] / self.min_segments).clamp(0, 1)
        reward = reach + info["is_grasped"].float() + near_axis + inside + info["pressed"].float()
        reward = reward + (info["pressed"] & ~info["touching_cable"]).float() * inside
        reward[info["success"]] = self.max_dense_reward
        return reward


CARRY_LIFT = 0.03  # the pinched capsule's bottom this far above the walls' top while the cable is carried
LIFT_STEPS = 10  # 3 mm a control step off the table
RELEASE_ABOVE_TOP = -0.002  # the pinched capsule's bottom this far above the walls' top when let go (below: in the slot;
# the tips' ends lie 3 mm above the capsule's bottom, so they stop 1 mm above the walls)
RELEASE_STEPS = 10
PRESS_DEPTH = 0.004  # the closed fingertips' ends this far below the seated cable's top
PRESS_STEPS = 10
PRESS_TAPS = (0.018, -0.018, 0.0)  # after the middle, press again this far along the slot's axis: over each
# neighbour, then over the middle again
TAP_LIFT = 0.012  # the fingers rise this much between presses
TAP_STEPS = 5  # control steps to rise and move over, and again to press down
CARRY_SERVO_STEPS = 20  # control steps servoing the pinched capsule over the slot's centre before lowering
LOWER_SERVO_STEPS = 25  # control steps lowering it onto the release height, still servoing
SERVO_GAIN = 0.3
SERVO_MAX_TURN = 0.3  # rad: the yaw correction's bound


def lay_over_clip(s: DrivenSolver, task: CableIntoClipHandEnv):
    """Scissor-pinch the middle capsule (fingers along the cable), lift it `CARRY_LIFT` over the clip's walls,
    carry it over the slot's centre while turning it onto the slot's axis, lower it until its bottom is
    `RELEASE_ABOVE_TOP` above the walls and open the fingers."""
    radius = task.rope_config.radius
    link = task.rope.links[task.grasp_segment]
    centre = link.pose.p.clone()
    centre[:, 2] = radius
    yaw = rope.segment_yaw(link.pose.q)
    tcp, q = DrivenSolver.scissor_pose(centre, yaw)
    s.set_ee("hand", "scissor_open", steps=1)
    s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
    s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
    s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
    top = task.clip.top
    carry = top + CARRY_LIFT + radius  # the pinched capsule's centre height while carried
    for k in range(1, LIFT_STEPS + 1):
        s.step({"arm": (s.above(tcp, (carry - radius) * k / LIFT_STEPS), q)})
    # over the slot: the fingers are symmetric, so of the two hand yaws along the axis take the one nearest
    # the hand's own (turn the short way: at most a quarter turn; measured from the capsule's `yaw` instead of the
    # hand's, the hand turned half way round on some seeds and the cable twisted off the axis in the pinch)
    axis = task.clip.axis()
    hand_yaw = DrivenSolver.neutral_yaw(yaw, np.pi)  # scissor_pose's (around 0)
    along = hand_yaw + DrivenSolver.neutral_yaw(axis - hand_yaw, np.pi)
    slot = task.clip.pose.p.clone()
    slot[:, 2] = carry
    s.move({"arm": DrivenSolver.scissor_pose(slot, along, around=along)}, max_steps=60, pos_tol=0.004, rot_tol=0.03)
    servo_capsule(s, task, slot, along, CARRY_SERVO_STEPS)
    slot[:, 2] = top + RELEASE_ABOVE_TOP + radius
    low, q_low = servo_capsule(s, task, slot, along, LOWER_SERVO_STEPS, descend=True)
    s.close_hand("hand", "scissor_open", ramp_steps=RELEASE_STEPS, hold_steps=5)
    return low, q_low


def servo_capsule(s: DrivenSolver, task: CableIntoClipHandEnv, goal: torch.Tensor, along: torch.Tensor, steps: int,
                  descend: bool = False):
    """Servo the pinched capsule (not the hand: the cable dragging over the table shifts and turns it in the
    pinch by up to 2 cm and several degrees) onto `goal` (n, 3) and the hand yaw `along`: every control step
    the TCP target moves by `SERVO_GAIN` of the capsule's remaining error in xy and yaw; `descend`: the target
    height ramps from where the capsule is to the goal's over the steps. Returns the last TCP target (p, q)."""
    link = task.rope.links[task.grasp_segment]
    corr, yaw_corr = torch.zeros_like(goal), torch.zeros_like(along)
    start_z = link.pose.p[:, 2].clone()
    for k in range(1, steps + 1):
        p = link.pose.p
        err = (goal - p) * torch.tensor([1.0, 1.0, 0.0], device=p.device)
        yaw_err = DrivenSolver.neutral_yaw(along - rope.segment_yaw(link.pose.q), np.pi)
        corr = corr + SERVO_GAIN * err
        yaw_corr = (yaw_corr + SERVO_GAIN * yaw_err).clamp(-SERVO_MAX_TURN, SERVO_MAX_TURN)
        target = goal + corr
        if descend:
            target[:, 2] = start_z + (goal[:, 2] - start_z) * min(1.0, k / (steps - 5))
        tcp, q = DrivenSolver.scissor_pose(target, along + yaw_corr, around=along)
        s.step({"arm": (tcp, q)})
    return tcp, q


def press_home(s: DrivenSolver, task: CableIntoClipHandEnv, low: torch.Tensor, q: torch.Tensor):
    """Rise 2 cm, swing the two fingers together and lower them onto the cable in the slot, their ends
    `PRESS_DEPTH` below the seated cable's top; hold, then withdraw upwards."""
    s.move({"arm": (s.above(low, 0.02), q)}, max_steps=15)
    s.close_hand("hand", "scissor", ramp_steps=5, hold_steps=0)
    # with the cable seated its centre lies at the slot's floor + radius; in the scissor pose the tips' ends
    # lie radius - 3 mm below the pinched capsule's centre, so this target puts them PRESS_DEPTH into the cable's top
    radius = task.rope_config.radius
    seated_top = CLIP_FLOOR + 2 * radius
    press = low.clone()
    press[:, 2] += (seated_top - PRESS_DEPTH) - (task.clip.top + RELEASE_ABOVE_TOP + 0.003)
    for k in range(1, PRESS_STEPS + 1):
        s.step({"arm": (s.above(low, 0.02) + (press - s.above(low, 0.02)) * k / PRESS_STEPS, q)})
    # then lift the fingers a little and press again over each neighbour (`PRESS_TAPS` along the slot's axis):
    # a neighbour left propped on the other or on a wall's edge is pushed home too (sliding the pressed
    # fingers instead dragged the cable along the slot by up to 2 cm)
    axis = task.clip.axis()
    along = torch.stack([torch.cos(axis), torch.sin(axis), torch.zeros_like(axis)], dim=1)
    here = press
    for offset in PRESS_TAPS:
        there = press + along * offset
        for k in range(1, TAP_STEPS + 1):  # up and over, then down
            s.step({"arm": (s.above(here + (there - here) * k / TAP_STEPS, TAP_LIFT), q)})
        for k in range(1, TAP_STEPS + 1):
            s.step({"arm": (s.above(there, TAP_LIFT * (1 - k / TAP_STEPS)), q)})
        here = there
    for _ in range(5):
        s.step()
    s.move({"arm": (s.above(low, APPROACH_HEIGHT / 2), q)}, max_steps=20)


@register_solver("CableIntoClipHand", control_modes=TCP_DELTA_MODES)
def solve_cable_into_clip_hand(env, seed: int) -> dict:
    """`lay_over_clip`, then `press_home`, then hold still until the task reports success."""
    with DrivenSolver.episode(env, seed) as s:
        task = env.unwrapped
        low, q = lay_over_clip(s, task)
        press_home(s, task, low, q)
        s.hold_until_success()
        return s.info
