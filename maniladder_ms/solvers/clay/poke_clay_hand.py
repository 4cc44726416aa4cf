"""Scripted solver of PokeClayHand (tasks/clay/poke_clay_hand.py): point the LEAP hand's index finger down and
push its tip into the block's top centre, then pull it back out.

1. Shape the hand to "point" (index finger straight down).
2. Bring the hand `APPROACH_HEIGHT` above the block's top centre, then the fingertip `POKE_START_ABOVE` above it.
3. Push the fingertip towards `POKE_DEPTH` below the top for `POKE_STEPS`.
4. Pull it back `WITHDRAW` above the top; hold still until success.
"""

from __future__ import annotations

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.clay.poke_clay_hand import PokeClayHandEnv

POKE_START_ABOVE = 0.02  # the fingertip stops this far above the top before the push
POKE_DEPTH = 0.025  # fingertip target below the top: past the 1 cm rule, the clay and the arm give way
POKE_STEPS = 15
WITHDRAW = 0.05  # the fingertip ends this far above the block's start top


@register_solver("PokeClayHand", control_modes=TCP_DELTA_MODES)
def solve_poke_clay_hand(env, seed: int) -> dict:
    """Point the index finger down, bring its tip above the block's top centre, push it into the clay,
    pull it back out."""
    with DrivenSolver.episode(env, seed) as s:
        task: PokeClayHandEnv = env.unwrapped
        q = top_down_quat(0.0, task.num_envs, device=task.device)
        s.set_ee("hand", "point", steps=1)
        dent = task.dent_point()
        s.move({"arm": (s.above(dent, APPROACH_HEIGHT), q)}, max_steps=40)
        # the fingertip's offset from the tcp, the finger pointing (world frame; the hand keeps its orientation)
        tip_offset = leap_fingertip(task.agent) - task.ee.tcp().p
        s.move({"arm": (s.above(dent, POKE_START_ABOVE) - tip_offset, q)}, max_steps=30)
        for _ in range(POKE_STEPS):
            s.step({"arm": (s.above(dent, -POKE_DEPTH) - tip_offset, q)})
        s.move({"arm": (s.above(dent, WITHDRAW) - tip_offset, q)}, max_steps=15, pos_tol=0.01)
        s.hold_until_success()
        return s.info
