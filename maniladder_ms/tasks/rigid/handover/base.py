"""The Handover family's base (HandoverCube, HandoverBallHands, HandoverMugHands, HandoverPenHands): one end
effector (the giver, the left) passes an object to the other (the taker, the right) in mid-air.

The family base `HandoverTask` holds the rule, `evaluate`, once for every embodiment; the task classes build
their object (`self.item`) and, where the taker puts it down, its target zone (`self.target`); their solvers are in
`maniladder_ms/solvers/rigid/handover/`. A task whose handover must be hand to hand sets `HAND_TO_HAND`; one whose
target is not a square zone on the table overrides `_placed`, and one whose pose origin is not the object's centre
`item_centre`.
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
    it, the giver does not touch it and it is at least `lift_height` above the table. A `HAND_TO_HAND` task
    further asks that both end effectors held the object at once, at least `lift_height` above the table,
    before the taker held it alone (episode memory `both_held`); a `GIVER_ALONE_FIRST` task asks that the giver
    held it alone first, at least `lift_height` above the table (`giver_held`), before both held it.
    """

    GIVER, TAKER = "left", "right"
    PARAMS = ("lift_height",)
    # set by the task's `_load_scene`: the object handed over, and the target zone marker (None: the taker keeps it)
    item = None
    target = None
    # True: the handover counts only after both end effectors held the object at once, its centre at least
    # `lift_height` above the table (episode memory `both_held`): a hand-to-hand pass, not a pick-up of an object
    # the giver dropped or put down
    HAND_TO_HAND = False
    # True: `giver_held` counts only while the giver holds the object alone (the taker neither holds nor touches it)
    # with its centre at least `lift_height` above the table, and `both_held` only after it: the pass starts from
    # the giver's own pick
    GIVER_ALONE_FIRST = False

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("giver_held")  # the giver has held the object
        if self.HAND_TO_HAND:
            self.memory.flag("both_held")  # ... both held it at once, off the table
        self.memory.flag("handed_over")  # ... and later the taker held it, mid-air, the giver off it

    def item_rest_height(self) -> float:
        """Centre height of the object resting on the table (tasks with a target zone)."""
        raise NotImplementedError

    def item_centre(self) -> torch.Tensor:
        """World centre (num_envs, 3) of the object (default: its pose's origin)."""
        return self.item.pose.p

    def _handover_state(self) -> dict[str, torch.Tensor]:
        giver, taker = self.GIVER, self.TAKER
        return {
            f"{giver}_grasped": self.ee.holds(self.item, giver),
            f"{taker}_grasped": self.ee.holds(self.item, taker),
            f"{giver}_touch": self.ee.touches(self.item, giver),
            f"{taker}_touch": self.ee.touches(self.item, taker),
            "is_lifted": self.item_centre()[:, 2] >= self.lift_height,
        }

    def _update_memory(self):
        now = self._handover_state()
        giver, taker = self.GIVER, self.TAKER
        swapped = now[f"{taker}_grasped"] & ~now[f"{giver}_grasped"] & ~now[f"{giver}_touch"] & now["is_lifted"]
        before = self.memory["both_held" if self.HAND_TO_HAND else "giver_held"]
        self.memory.latch("handed_over", before & swapped)
        held = now[f"{giver}_grasped"]
        if self.GIVER_ALONE_FIRST:
            held = held & ~now[f"{taker}_grasped"] & ~now[f"{taker}_touch"] & now["is_lifted"]
        self.memory.latch("giver_held", held)
        if self.HAND_TO_HAND:
            both = now[f"{giver}_grasped"] & now[f"{taker}_grasped"] & now["is_lifted"] & self.memory["giver_held"]
            self.memory.latch("both_held", both)

    def evaluate(self):
        info = self._handover_state()
        giver, taker = self.GIVER, self.TAKER
        info["giver_held"] = self.memory["giver_held"]
        if self.HAND_TO_HAND:
            info["both_held"] = self.memory["both_held"]
        info["handed_over"] = self.memory["handed_over"]
        if self.target is None:
            delivered = info[f"{taker}_grasped"] & ~info[f"{giver}_touch"] & info["is_lifted"]
        else:
            info["placed"] = self._placed(info)
            delivered = info["placed"] & ~info[f"{giver}_touch"] & ~info[f"{taker}_touch"]
        info["success"] = info["handed_over"] & delivered
        return info

    def _placed(self, info: dict) -> torch.Tensor:
        """The object rests in the target (default: a square zone of `zone_half` on the table, the object's
        centre less than `on_table_tol` above its resting height); adds its parts to `info`."""
        offset = self.item.pose.p - self.target.pose.p
        info["in_zone"] = (offset[:, :2].abs() <= self.zone_half).all(dim=1)
        on_table = self.item.pose.p[:, 2] < self.item_rest_height() + self.on_table_tol
        return info["in_zone"] & on_table
