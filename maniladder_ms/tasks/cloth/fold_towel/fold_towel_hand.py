"""FoldTowelHand (L3 deformable SX): fold a flat towel in half along its short axis with one LEAP hand."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from .base import TowelInHalfTask


@register_task("FoldTowelHand")
class FoldTowelHandEnv(TowelInHalfTask):
    """**Task:** a rectangular towel lies flat on the table; fold it in half along its short axis with the
    LEAP hand: take the far short edge (by a corner), lift it and lay it onto the other short edge, so the
    towel lies doubled, half its length, and let go.

    **Randomisation:** the towel (`cloth.towel(10, 6)`: 10 x 6 particles 2.5 cm apart, a 25 x 15 cm sheet,
    particles of 10 mm radius, as FoldTowelInHalf) lies flat, centred at x uniform in `towel_x_range`, y
    uniform in +-`towel_max_y`, its long axis turned by a yaw uniform in +-`towel_max_yaw`.

    **Success:** folded along the short axis: the particles paired by that fold (`cloth.fold_pairs` across the
    long axis: each row with the row as far from the other short edge, the two short edges together) lie, on
    average, at most `fold_tol` from each other seen from above (`cloth.fold_distance(..., top_down=True)`:
    the two layers keep two particle radii between them, the cloth's thickness, not a fold error); the towel
    lies on the table (no particle centre higher than `max_height` above it); and the hand has let go (touches
    no particle of the towel, `ee.touches`).

    **Level 3:** its Level-2 suite-mate FoldTowelInHalf folds the same towel by the same rule with a parallel
    gripper, whose fingers open 4 cm around a corner particle and close on it from above. The LEAP hand has no
    gripper: the only hold on a 1 cm particle lying on the table is the scissor pinch, the sides of the index and
    middle fingertips swung together with the tips' middle 5 mm outwards of the corner, their inner ends 1-3 mm
    short of its two edge neighbours (a few-millimetre window; a thumb-index pinch takes no cloth particle off
    the table), and the corner rolls away under a fingertip that presses on it. A second carry with that pinch
    (the edge's other corner, as FoldTowelInHalf's gripper does) lost the corner on the way and left the fold
    at 3 cm, so one pinched corner must bring the whole far half over: 30 particle pairs against a 2 cm mean,
    the unheld corner of the carried edge dragged 22.5 cm through the air by the sheet alone. Demos take ~150
    steps, 3 stages (pinch, carry over in an arc, lay and let go): T = 10 log10 150 + 3 = 24.8, under
    FoldTowelInHalf's 27.0 (two carries); the rung is the embodiment's grasp (C_proc 4 against 3: the pinch is a
    strict tolerance), not the length.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
