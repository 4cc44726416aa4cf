"""One end-effector vocabulary for every ManiLadder agent: what a task's rule, reward and solver ask of
the robot's hands, whatever the embodiment (robosuite's `_check_grasp(gripper, obj)`, for five agents).

`EndEffectors(agent, scene)` (a task has it as `self.ee`) names the agent's end effectors, `sides`:
("left", "right") for the two-arm agents, ("main",) for the single-arm ones. Per side:

- `tcp(side)`: the TCP pose (batched `Pose`);
- `holds(obj, side)`: the object is held: a gripper's two fingers press on it from opposite sides
  (>= `GRIPPER_HOLD_FORCE`, ManiSkill's Panda check); a LEAP hand pinches it between a finger and the
  thumb or palm, or between the index and middle fingers (the "scissor" pinch of ropes and cloth),
  each link >= `LEAP_CONTACT_FORCE`;
- `touches(obj, side)`: any link of the end effector (gripper hand and fingers; LEAP palm, fingers,
  thumb) presses on it (>= `TOUCH_FORCE`);
- `is_open(side)`: a gripper's fingers are apart by more than `GRIPPER_OPEN_FRACTION` of their range;
  a LEAP hand is flat (every hand joint within `LEAP_OPEN_TOLERANCE` of 0, the "open" synergy).

`obj` is anything with contacts: a rigid actor, an articulation link (a rope segment, a lid), a cloth
particle, or a list of them (held / touched if any is). `side=None` asks "any end effector" for `holds`
/ `touches` / `is_open` (all of them for `is_open`) and "the only one" for `tcp`. All answers are
(num_envs,) bool tensors, batched over sub-scenes.

Contact answers are cached per (question, object, side) until `new_state()`, which the env calls after
every physics step, reset and state restore (`ManiLadderEnv`): a task's memory update and `evaluate` of
one control step, which both ask, share one contact pass (a pass over a LEAP hand's links costs about
as much as the rest of a control step on the CPU).

PhysX lists the contacts of its last step, so after a reset (bodies placed, nothing simulated) the list
still describes where the previous episode's step left things: a hand that touched the object then
"held" it in the new episode's first observation. `mark_placed` (the env calls it at every reset) makes
every force of this module zero for the reset sub-scenes until `mark_simulated` (after the next physics
step): a reset scene has no contact forces. A state restore (`set_state_dict`) keeps the last step's
list: restoring the state that step produced (a replay, `demos verify`) answers as that step did.
"""

from __future__ import annotations

import weakref
from typing import Optional, Sequence

import numpy as np
import torch

from mani_skill.utils import common, sapien_utils
from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

SINGLE = "main"  # the side name of a single-arm agent's one end effector
TOUCH_FORCE = 0.05  # N: a link presses on an object above this (LEAP's contact threshold)
LEAP_CONTACT_FORCE = 0.05  # N: each side of a LEAP pinch presses at least this
GRIPPER_HOLD_FORCE = 0.5  # N: each finger of a gripper hold (ManiSkill's Panda.is_grasping)
GRIPPER_HOLD_ANGLE = 85.0  # deg: a finger's force at most this far from its closing direction (ManiSkill's)
GRIPPER_OPEN_FRACTION = 0.8  # of the finger travel (0.04 m each)
GRIPPER_MAX_OPENING = 0.04  # m per finger (the Panda's)
LEAP_OPEN_TOLERANCE = 0.35  # rad

LEAP_FINGERS = ("index", "middle", "ring")
LEAP_FINGER_LINKS = tuple(f"leap_{f}_{s}" for f in LEAP_FINGERS for s in ("pip", "dip", "tip"))
LEAP_THUMB_LINKS = ("leap_thumb_pip", "leap_thumb_dip", "leap_thumb_tip")
LEAP_PALM_LINKS = ("leap_palm",)
LEAP_SCISSOR_LINKS = {"index": ("leap_index_dip", "leap_index_tip"), "middle": ("leap_middle_dip", "leap_middle_tip")}
GRIPPER_FINGER_LINKS = ("panda_leftfinger", "panda_rightfinger")
GRIPPER_HAND_LINKS = ("panda_hand",)


_PLACED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()  # scene -> (num_envs,) bool: reset, not stepped


def mark_placed(scene, env_idx: torch.Tensor) -> None:
    """Sub-scenes `env_idx` of `scene` were placed (a reset) since the last physics step: their contact
    forces read zero until `mark_simulated` (see the module docstring)."""
    placed = _PLACED.get(scene)
    if placed is None:
        placed = _PLACED[scene] = torch.zeros(scene.num_envs, dtype=torch.bool, device=scene.device)
    placed[env_idx] = True


def mark_simulated(scene) -> None:
    """`scene` took a physics step: its contact list describes its bodies again."""
    _PLACED.pop(scene, None)


def _zero_placed(scene, forces: torch.Tensor) -> torch.Tensor:
    """`forces` (..., num_envs, 3) with the sub-scenes placed since the last physics step zeroed."""
    placed = _PLACED.get(scene)
    if placed is None:
        return forces
    return forces * (~placed).to(forces.dtype)[:, None].to(forces.device)


def contact_forces(scene, obj, links) -> torch.Tensor:
    """(len(links), num_envs, 3) contact forces ON each of `links` FROM `obj` (what ManiSkill's
    `scene.get_pairwise_contact_forces(link, obj)` gives). On the CPU that query lists every contact of the
    scene for each pair (a LEAP hand's 13 links over 455 contacts with 60 grains in a glass: an evaluate took
    as long as the step); here one pass over the contacts serves all links."""
    if scene.gpu_sim_enabled:
        return _zero_placed(scene, torch.stack([scene.get_pairwise_contact_forces(link, obj) for link in links]))
    entities = [link._bodies[0].entity for link in links]
    by_link = sapien_utils.get_multiple_pairwise_contacts(scene.px.get_contacts(), obj._bodies[0].entity, entities)
    # compute_total_impulse gives the impulse on the first entity of the query, `obj`: negate for the link's
    impulses = [-common.to_tensor(sapien_utils.compute_total_impulse(by_link[e]))[None, :] for e in entities]
    return _zero_placed(scene, torch.stack([impulse / scene.px.timestep for impulse in impulses]).float())


def pair_forces(scene, objs, links) -> torch.Tensor:
    """(len(objs), len(links), num_envs, 3) contact forces ON each link FROM each object: `contact_forces` of
    many objects in ONE pass over the CPU contact list (clay particles, rope capsules, cloth particles: a
    query per object made a clay squeeze step 8x slower). Impulses are summed in the same order, so each
    (object, link) force equals `contact_forces`' exactly."""
    if scene.gpu_sim_enabled:
        return torch.stack([contact_forces(scene, obj, links) for obj in objs])
    obj_index = {obj._bodies[0].entity.global_id: i for i, obj in enumerate(objs)}
    link_index = {link._bodies[0].entity.global_id: j for j, link in enumerate(links)}
    total = np.zeros((len(objs), len(links), 3))
    for contact in scene.px.get_contacts():
        first, second = contact.bodies[0].entity.global_id, contact.bodies[1].entity.global_id
        if first in obj_index and second in link_index:
            # the impulse acts on the first body, the object: the link takes its negative
            i, j, sign = obj_index[first], link_index[second], -1.0
        elif second in obj_index and first in link_index:
            i, j, sign = obj_index[second], link_index[first], 1.0
        else:
            continue
        total[i, j] += sign * np.sum([point.impulse for point in contact.points], axis=0)
    # float32 before dividing, as `contact_forces` (ManiSkill's to_tensor makes float32), for equal bits
    return _zero_placed(scene, (torch.from_numpy(total).float() / scene.px.timestep)[:, :, None, :])


def link_forces(scene, obj, links) -> torch.Tensor:
    """(len(links), num_envs) magnitudes of `contact_forces`."""
    return contact_forces(scene, obj, links).norm(dim=-1)


def _y_axis(q: torch.Tensor) -> torch.Tensor:
    """(n, 3) the local y axis of the rotations `q` (n, 4; wxyz) in world: the rotation matrix's second column,
    computed as ManiSkill's `quaternion_to_matrix` computes it (the same bits) without the other six entries
    (the full matrix was ~15 % of a two-gripper step's time, ScrewNutOnBolt's four holds a step)."""
    r, i, j, k = torch.unbind(q, -1)
    two_s = 2.0 / (q * q).sum(-1)
    return torch.stack((two_s * (i * j - k * r), 1 - two_s * (i * i + k * k), two_s * (j * k + i * r)), -1)


def _as_list(obj) -> list:
    return list(obj) if isinstance(obj, (list, tuple)) else [obj]


class _Effector:
    """One end effector (a gripper or a LEAP hand) of an agent; `prefix` "" / "left_" / "right_"."""

    kind: str

    def __init__(self, agent, prefix: str, tcp_link):
        self.agent, self.prefix, self.tcp_link = agent, prefix, tcp_link

    def link(self, name: str):
        return self.agent.robot.links_map[self.prefix + name]

    def holds(self, scene, obj) -> torch.Tensor:
        return self._any(obj, lambda o: self._holds_one(scene, o))

    def touches(self, scene, obj) -> torch.Tensor:
        pressing = pair_forces(scene, _as_list(obj), self.all_links).norm(dim=-1) >= TOUCH_FORCE
        return pressing.any(dim=1).any(dim=0)

    @staticmethod
    def _any(obj, fn) -> torch.Tensor:
        out = None
        for o in _as_list(obj):
            flag = fn(o)
            out = flag if out is None else out | flag
        return out


class Gripper(_Effector):
    kind = "gripper"

    def __init__(self, agent, prefix: str, tcp_link):
        super().__init__(agent, prefix, tcp_link)
        self.fingers = [self.link(n) for n in GRIPPER_FINGER_LINKS]
        self.all_links = [self.link(n) for n in GRIPPER_HAND_LINKS] + self.fingers
        joints = [j.name for j in agent.robot.get_active_joints()]
        self.finger_joints = [joints.index(prefix + f"panda_finger_joint{i}") for i in (1, 2)]

    def _holds_one(self, scene, obj) -> torch.Tensor:
        forces = contact_forces(scene, obj, self.fingers)
        flags = []
        for finger, force, sign in zip(self.fingers, forces, (1, -1)):
            opening = sign * _y_axis(finger.pose.q)  # the direction it opens
            angle = torch.rad2deg(common.compute_angle_between(opening, force))
            flags.append((force.norm(dim=1) >= GRIPPER_HOLD_FORCE) & (angle <= GRIPPER_HOLD_ANGLE))
        return flags[0] & flags[1]

    def is_open(self) -> torch.Tensor:
        q = self.agent.robot.get_qpos()[:, self.finger_joints]
        return (q >= GRIPPER_OPEN_FRACTION * GRIPPER_MAX_OPENING).all(dim=1)


class LeapHand(_Effector):
    kind = "leap"

    def __init__(self, agent, prefix: str, tcp_link):
        super().__init__(agent, prefix, tcp_link)
        self.fingers = [self.link(n) for n in LEAP_FINGER_LINKS]
        self.thumb_palm = [self.link(n) for n in LEAP_THUMB_LINKS + LEAP_PALM_LINKS]
        self.all_links = self.fingers + self.thumb_palm
        index = [LEAP_FINGER_LINKS.index(n) for n in LEAP_SCISSOR_LINKS["index"]]
        middle = [LEAP_FINGER_LINKS.index(n) for n in LEAP_SCISSOR_LINKS["middle"]]
        self._scissor = (index, middle)
        joints = [j.name for j in agent.robot.get_active_joints()]
        self.hand_joints = [joints.index(prefix + f"leap_j{i}") for i in range(16)]

    def _pressing(self, scene, obj) -> torch.Tensor:
        """(13, num_envs) bool: fingers (9), then thumb (3) and palm, each pressing on `obj`."""
        return link_forces(scene, obj, self.all_links) >= LEAP_CONTACT_FORCE

    def _holds_one(self, scene, obj) -> torch.Tensor:
        return self.grip_kinds(scene, obj).any(dim=0)

    def grip_kinds(self, scene, obj) -> torch.Tensor:
        """(2, num_envs) bool: [a finger against the thumb or palm (power / pinch grasps), the index against
        the middle finger (scissor pinch)]."""
        pressing = self._pressing(scene, obj)
        n = len(self.fingers)
        fingers, thumb_palm = pressing[:n], pressing[n:]
        index, middle = self._scissor
        grasp = fingers.any(dim=0) & thumb_palm.any(dim=0)
        scissor = pressing[index].any(dim=0) & pressing[middle].any(dim=0)
        return torch.stack([grasp, scissor])

    def is_open(self) -> torch.Tensor:
        q = self.agent.robot.get_qpos()[:, self.hand_joints]
        return (q.abs() <= LEAP_OPEN_TOLERANCE).all(dim=1)


class EndEffectors:
    """The end effectors of `agent` by side (see the module docstring)."""

    def __init__(self, agent, scene):
        self.agent, self.scene = agent, scene
        links = agent.robot.links_map
        if "left_leap_tcp" in links or "left_panda_hand_tcp" in links:
            prefixes = {"left": "left_", "right": "right_"}
        else:
            prefixes = {SINGLE: ""}
        self._by_side = {}
        for side, prefix in prefixes.items():
            if prefix + "leap_tcp" in links:
                self._by_side[side] = LeapHand(agent, prefix, links[prefix + "leap_tcp"])
            elif prefix + "panda_hand_tcp" in links:
                self._by_side[side] = Gripper(agent, prefix, links[prefix + "panda_hand_tcp"])
            else:
                raise ValueError(f"agent {agent.uid!r}: no known end effector (gripper or LEAP hand) for side {side!r}")
        self.sides: tuple[str, ...] = tuple(self._by_side)
        self._cache: dict = {}

    def new_state(self):
        """Forget the cached contact answers: the scene has stepped or its state was set."""
        self._cache.clear()

    def _cached(self, question: str, obj, side: str) -> torch.Tensor:
        """`side`'s answer to `holds` / `touches` (`question`) for `obj`, computed once until `new_state`."""
        objs = tuple(_as_list(obj))
        key = (question, side, tuple(id(o) for o in objs))
        if key not in self._cache:  # the entry keeps its objects alive, so no other object can take their ids meanwhile
            self._cache[key] = (objs, getattr(self[side], question)(self.scene, obj))
        return self._cache[key][1]

    def __getitem__(self, side: str) -> _Effector:
        if side not in self._by_side:
            raise KeyError(f"{self.agent.uid} has no end effector {side!r}; its end effectors: {', '.join(self.sides)}")
        return self._by_side[side]

    @property
    def kind(self) -> str:
        """"gripper" or "leap" (every agent has one kind on all its sides)."""
        return self[self.sides[0]].kind

    def _side(self, side: Optional[str]) -> str:
        if side is None:
            if len(self.sides) > 1:
                raise ValueError(f"{self.agent.uid} has end effectors {self.sides}: name one")
            return self.sides[0]
        return side

    def tcp_link(self, side: Optional[str] = None):
        return self[self._side(side)].tcp_link

    def tcp(self, side: Optional[str] = None):
        """Batched world pose of a TCP (`side` None: the only one)."""
        return self.tcp_link(side).pose

    def _each(self, side: Optional[str], fn, reduce=torch.Tensor.__or__) -> torch.Tensor:
        sides: Sequence[str] = self.sides if side is None else (side,)
        out = None
        for s in sides:
            flag = fn(s)
            out = flag if out is None else reduce(out, flag)
        return out

    def holds(self, obj, side: Optional[str] = None) -> torch.Tensor:
        """(num_envs,) bool: `obj` (or any of a list) is held by `side` (None: by any end effector)."""
        # a copy of the cached answer: callers may change theirs in place
        return self._each(side, lambda s: self._cached("holds", obj, s)).clone()

    def touches(self, obj, side: Optional[str] = None) -> torch.Tensor:
        """(num_envs,) bool: `side` (None: any end effector) presses on `obj` (or any of a list)."""
        return self._each(side, lambda s: self._cached("touches", obj, s)).clone()

    def is_open(self, side: Optional[str] = None) -> torch.Tensor:
        """(num_envs,) bool: `side` is open (None: every end effector is)."""
        return self._each(side, lambda s: self[s].is_open(), reduce=torch.Tensor.__and__)


# centre of the end face of a LEAP finger's tip (index, middle, ring) in its tip link's frame: the end of
# the tip's collision box (scripts/make_agents.py), the finger running along the link's -y (a left hand,
# reflected in y, along +y)
LEAP_TIP_END = (0.0, -0.0495, 0.0145)


def leap_fingertip(agent, finger: str = "index", prefix: str = "") -> torch.Tensor:
    """World position (num_envs, 3) of the end of a LEAP finger (index, middle, ring), where it presses;
    `prefix` "left_" / "right_" picks a hand of a two-arm agent."""
    tip = agent.robot.links_map[f"{prefix}leap_{finger}_tip"].pose
    x, y, z = LEAP_TIP_END
    end = torch.tensor((x, -y if prefix.startswith("left") else y, z), dtype=tip.p.dtype, device=tip.p.device)
    end = end.expand_as(tip.p)
    return tip.p + quaternion_apply(tip.q, end)
