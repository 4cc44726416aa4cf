"""Is a LEAP hand holding an object? Contact forces between the object and the hand's finger and thumb
links, batched over sub-scenes (for task `evaluate`s)."""

from __future__ import annotations

import torch

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
        forces = torch.stack([scene.get_pairwise_contact_forces(obj, link).norm(dim=1) for link in links])
        return (forces >= CONTACT_FORCE).any(dim=0)

    def touches(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: any link of the hand touches `obj`."""
        return self._touch(scene, self.fingers + self.thumb + self.palm, obj)

    def is_grasping(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: the object is pinched between a finger and the thumb (or the palm)."""
        return self._touch(scene, self.fingers, obj) & self._touch(scene, self.thumb + self.palm, obj)

    def is_scissoring(self, scene, obj) -> torch.Tensor:
        """(num_envs,) bool: the object is held between the index and the middle finger (the "scissor" synergy)."""
        return self._touch(scene, self.scissor["index"], obj) & self._touch(scene, self.scissor["middle"], obj)
