"""The CatchBall family's base (TossCatchCube; the Level 4 rows CatchBallHand and ThrowCatchBallHands): an object
flies free through the air and an end effector catches it before it lands.

The family base `CatchTask` holds the flight bookkeeping in episode memory and the catch rule, `evaluate`, once for
every embodiment; the task classes build their object (`self.item`) and its layout. A flight is told from a carry
by physics, not by a pose: at a free control step the object's velocity changed by gravity alone, so nothing (no
gripper, hand, arm link or table) pushed it during any of the step's physics steps.
"""

from __future__ import annotations

import torch

from maniladder_ms.agents.effectors import contact_forces
from maniladder_ms.envs import ManiLadderEnv

GRAVITY = (0.0, 0.0, -9.81)  # m/s^2, the scene's (ManiSkill's default)
TABLE_CONTACT_FORCE = 1e-3  # N: the object touches the table above this (a resting object presses ~0.6 N)
THROWER_HELD, CATCHER_HELD = 1.0, -1.0  # memory `holder`: who held the object last (0: nobody yet)


class CatchTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the object was tossed: after the thrower had held it clear
    of the table (its centre higher than its bounding radius, `ITEM_RADIUS`), it flew free for at least
    `min_flight_steps` consecutive control steps (at each, neither end effector touched it, `ee.touches`, and
    its velocity changed over the step by gravity alone, within `flight_tol`: nothing else pushed it either), the thrower being the last to have held it, and over that
    stretch its centre travelled at least `min_toss_distance` horizontally from where the stretch began (episode
    memory `tossed`); after the toss the thrower never touched it again (`thrower_again`, never set) and the
    object never touched the table after the thrower first held it clear of it (`touched_table`, checked at
    every physics step, never set); and now the catcher holds it (`ee.holds`), the thrower does not touch it
    and its centre is at least `lift_height` above the table. A task without a thrower (`THROWER` None: the
    scene launches the object) counts a flight from the start of the episode.
    """

    THROWER, CATCHER = "left", "right"
    PARAMS = ("lift_height", "min_flight_steps", "min_toss_distance", "flight_tol")
    # set by the task's `_load_scene`: the object tossed and caught
    item = None
    # the object's bounding radius (m), plus a margin: it is picked once held with its centre higher than this, and
    # the table contact is queried only while its centre is this close to the table top (set by the task)
    ITEM_RADIUS = 0.05

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("picked")  # the thrower has held the object clear of the table
        self.memory.flag("touched_table")  # ... and since then the object touched the table
        self.memory.value("holder")  # who held it last: THROWER_HELD, CATCHER_HELD, 0 nobody yet
        self.memory.value("last_velocity", 3)  # its linear velocity after the last control step
        self.memory.value("flight_start", 3)  # its centre at the last control step it was not flying
        self.memory.counter("airborne_steps")  # consecutive control steps of free flight so far
        self.memory.value("flight_travel")  # horizontal travel of the current free stretch (m)
        self.memory.flag("tossed")  # a free stretch long and far enough, from the thrower
        self.memory.flag("thrower_again")  # the thrower touched the object after the toss
        self.memory.flag("caught")  # after the toss the catcher held it, the thrower off it

    def _initialize_episode(self, env_idx, options: dict):
        super()._initialize_episode(env_idx, options)
        if self.THROWER is None:
            self.memory.store("holder", torch.full((len(env_idx), 1), THROWER_HELD), env_idx)

    def item_centre(self) -> torch.Tensor:
        """World centre (num_envs, 3) of the object (default: its pose's origin)."""
        return self.item.pose.p

    def item_on_table(self) -> torch.Tensor:
        """(num_envs,) bool: the object touches the table (a contact query only where its centre is within
        `ITEM_RADIUS` of the table top)."""
        near = self.item_centre()[:, 2] < self.ITEM_RADIUS
        if not bool(near.any()):
            return near
        force = contact_forces(self.scene, self.ladder_scene.table, [self.item])[0].norm(dim=1)
        return near & (force > TABLE_CONTACT_FORCE)

    def _after_simulation_step(self):
        super()._after_simulation_step()
        # "never touched the table" is checked at every physics step: a bounce lasts less than a control step
        watch = self.memory["picked"] & ~self.memory["touched_table"]
        if bool(watch.any()):
            self.memory.latch("touched_table", watch & self.item_on_table())

    def _catch_state(self) -> dict[str, torch.Tensor]:
        info = {"catcher_grasped": self.ee.holds(self.item, self.CATCHER),
                "catcher_touch": self.ee.touches(self.item, self.CATCHER),
                "is_lifted": self.item_centre()[:, 2] >= self.lift_height}
        if self.THROWER is not None:
            info["thrower_grasped"] = self.ee.holds(self.item, self.THROWER)
            info["thrower_touch"] = self.ee.touches(self.item, self.THROWER)
        else:
            info["thrower_grasped"] = info["thrower_touch"] = torch.zeros_like(info["is_lifted"])
        return info

    def _update_memory(self):
        now = self._catch_state()
        p, v = self.item_centre(), self.item.linear_velocity
        if self.THROWER is None:
            self.memory.latch("picked", torch.ones_like(now["is_lifted"]))
        else:
            # clear of the table: its centre higher than its bounding radius (a grasp squeezing an object on the
            # table lifts it off for a physics step or two)
            self.memory.latch("picked", now["thrower_grasped"] & (p[:, 2] > self.ITEM_RADIUS))
        holder = self.memory["holder"][:, 0]
        holder = torch.where(now["catcher_grasped"], CATCHER_HELD, holder)
        holder = torch.where(now["thrower_grasped"], THROWER_HELD, holder)
        self.memory.store("holder", holder[:, None])
        # free flight: no end effector on it and its velocity changed by gravity alone over the step
        gravity = torch.tensor(GRAVITY, device=self.device)
        expected = self.memory["last_velocity"] + gravity * self.control_timestep
        ballistic = (v - expected).norm(dim=1) <= self.flight_tol
        free = self.memory["picked"] & ballistic & ~now["thrower_touch"] & ~now["catcher_touch"]
        self.memory.count("airborne_steps", free, consecutive=True)
        start = self.memory["flight_start"]
        travel = (p[:, :2] - start[:, :2]).norm(dim=1)
        self.memory.store("flight_travel", torch.where(free, travel, 0.0)[:, None])
        self.memory.store("flight_start", torch.where(free[:, None], start, p))
        self.memory.store("last_velocity", v)
        tossed_before = self.memory["tossed"]
        self.memory.latch("thrower_again", tossed_before & now["thrower_touch"])
        toss = (free & (self.memory["airborne_steps"] >= self.min_flight_steps)
                & (travel >= self.min_toss_distance) & (holder == THROWER_HELD))
        self.memory.latch("tossed", toss)
        self.memory.latch("caught", tossed_before & now["catcher_grasped"] & ~now["thrower_touch"])

    def evaluate(self):
        info = self._catch_state()
        for name in ("picked", "tossed", "touched_table", "thrower_again", "caught"):
            info[name] = self.memory[name]
        info["airborne_steps"] = self.memory["airborne_steps"]
        held = info["catcher_grasped"] & ~info["thrower_touch"] & info["is_lifted"]
        info["success"] = info["caught"] & ~info["thrower_again"] & ~info["touched_table"] & held
        return info
