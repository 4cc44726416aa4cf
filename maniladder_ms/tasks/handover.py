"""The Handover family's rule (HandoverCube, HandoverBallHands; later HandoverMugHands, HandoverPenHands):
one end effector (the giver, the left) passes an object to the other (the taker, the right) in mid-air.

The family base `HandoverTask` holds the rule, `evaluate`, once for every embodiment; the task classes build
their object (`self.item`) and, where the taker puts it down, its target zone (`self.target`), and keep their
solvers.
"""

from __future__ import annotations

import torch

from maniladder_ms.envs import ManiLadderEnv


class HandoverTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the handover happened: the taker held the object while
    the giver neither held nor touched it and its centre was at least `lift_height` above the table, after
    the giver had held it (episode memory `handed_over`); then, for a task with a target zone
    (`self.target`, a square of `zone_half`), the object rests in it on the table (centre less than
    `on_table_tol` above its resting height) touched by neither end effector; without one, the taker holds
    it, the giver does not touch it and it is at least `lift_height` above the table.
    """

    GIVER, TAKER = "left", "right"
    PARAMS = ("lift_height",)
    # set by the task's `_load_scene`: the object handed over, and the target zone marker (None: the taker keeps it)
    item = None
    target = None

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("giver_held")  # the giver has held the object
        self.memory.flag("handed_over")  # ... and later the taker held it, mid-air, the giver off it

    def item_rest_height(self) -> float:
        """Centre height of the object resting on the table (tasks with a target zone)."""
        raise NotImplementedError

    def _handover_state(self) -> dict[str, torch.Tensor]:
        giver, taker = self.GIVER, self.TAKER
        return {
            f"{giver}_grasped": self.ee.holds(self.item, giver),
            f"{taker}_grasped": self.ee.holds(self.item, taker),
            f"{giver}_touch": self.ee.touches(self.item, giver),
            f"{taker}_touch": self.ee.touches(self.item, taker),
            "is_lifted": self.item.pose.p[:, 2] >= self.lift_height,
        }

    def _update_memory(self):
        now = self._handover_state()
        giver, taker = self.GIVER, self.TAKER
        swapped = now[f"{taker}_grasped"] & ~now[f"{giver}_grasped"] & ~now[f"{giver}_touch"] & now["is_lifted"]
        self.memory.latch("handed_over", self.memory["giver_held"] & swapped)
        self.memory.latch("giver_held", now[f"{giver}_grasped"])

    def evaluate(self):
        info = self._handover_state()
        giver, taker = self.GIVER, self.TAKER
        info["giver_held"] = self.memory["giver_held"]
        info["handed_over"] = self.memory["handed_over"]
        if self.target is None:
            delivered = info[f"{taker}_grasped"] & ~info[f"{giver}_touch"] & info["is_lifted"]
        else:
            offset = self.item.pose.p - self.target.pose.p
            info["in_zone"] = (offset[:, :2].abs() <= self.zone_half).all(dim=1)
            on_table = self.item.pose.p[:, 2] < self.item_rest_height() + self.on_table_tol
            info["placed"] = info["in_zone"] & on_table
            delivered = info["placed"] & ~info[f"{giver}_touch"] & ~info[f"{taker}_touch"]
        info["success"] = info["handed_over"] & delivered
        return info
