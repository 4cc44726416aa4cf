"""Is a LEAP hand holding an object? Contact forces between the object and the hand's finger and thumb
links, batched over sub-scenes (for task `evaluate`s)."""

from __future__ import annotations

import torch

from mani_skill.utils import common, sapien_utils

FINGERS = ("index", "middle", "ring")
FINGER_LINKS = [f"leap_{f}_{s}" for f in FINGERS for s in ("pip", "dip", "tip")]
SCISSOR_LINKS = {"index": ["leap_index_dip", "leap_index_tip"], "middle": ["leap_middle_dip", "leap_middle_tip"]}
THUMB_LINKS = ["leap_thumb_pip", "leap_thumb_dip", "leap_thumb_tip"]
PALM_LINKS = ["leap_palm"]
CONTACT_FORCE = 0.05  # N: a link touches the object above this


class LeapContacts:
    """The finger, thumb and palm links of one LEAP hand (`prefix`: "" / "left_" / "right_")."""

    def __init__(self, agent, prefix: str = ""):
        self.fingers = [agent.link(prefix + name) for name in FINGER_LINKS]
        self.thumb = [agent.link(prefix + name) for name in THUMB_LINKS]
        self.palm = [agent.link(prefix + name) for name in PALM_LINKS]
        self.scissor = {f: [agent.link(prefix + name) for name in names] for f, names in SCISSOR_LINKS.items()}

    @staticmethod
    def _touch(scene, links, obj) -> torch.Tensor:
        return (link_forces(scene, obj, links) >= CONTACT_FORCE).any(dim=0)

    def touches(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: any link of the hand touches `obj`."""
        return self._touch(scene, self.fingers + self.thumb + self.palm, obj)

    def is_grasping(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: the object is pinched between a finger and the thumb (or the palm)."""
        return self._both_touch(scene, obj, self.fingers, self.thumb + self.palm)

    def is_scissoring(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: the object is held between the index and the middle finger (the "scissor" synergy)."""
        return self._both_touch(scene, obj, self.scissor["index"], self.scissor["middle"])

    @staticmethod
    def _both_touch(scene, obj, first, second) -> torch.Tensor:
        """(num_envs,) bool: a link of `first` and a link of `second` touch `obj` (one contact query for both)."""
        touching = link_forces(scene, obj, first + second) >= CONTACT_FORCE
        return touching[: len(first)].any(dim=0) & touching[len(first):].any(dim=0)


def link_forces(scene, obj, links) -> torch.Tensor:
    """(len(links), num_envs) magnitudes of the contact forces between `obj` and each of `links`, as
    ManiSkill's `scene.get_pairwise_contact_forces` gives them. On the CPU that query lists every contact of the
    scene for each pair (a LEAP hand's 13 links over 455 contacts with 60 grains in a glass: an evaluate took as
    long as the step); here one pass over the contacts serves all links, summed in the same order."""
    if scene.gpu_sim_enabled:
        return torch.stack([scene.get_pairwise_contact_forces(obj, link).norm(dim=1) for link in links])
    entities = [link._bodies[0].entity for link in links]
    by_link = sapien_utils.get_multiple_pairwise_contacts(scene.px.get_contacts(), obj._bodies[0].entity, entities)
    impulses = [common.to_tensor(sapien_utils.compute_total_impulse(by_link[e]))[None, :] for e in entities]
    return torch.stack([(impulse / scene.px.timestep).norm(dim=1) for impulse in impulses])
