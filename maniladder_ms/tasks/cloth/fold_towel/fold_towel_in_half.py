"""FoldTowelInHalf (L2 deformable SG): fold a flat towel in half along its short axis, short edge onto short edge."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from .base import TowelInHalfTask


@register_task("FoldTowelInHalf")
class FoldTowelInHalfEnv(TowelInHalfTask):
    """**Task:** a rectangular towel lies flat on the table; fold it in half along its short axis: take
    one short edge, lift it and lay it onto the other short edge, so the towel lies doubled, half its
    length, and let go.

    **Randomisation:** the towel (`cloth.towel(10, 6)`: 10 x 6 particles 2.5 cm apart, a 25 x 15 cm
    sheet, particles of 10 mm radius so a folded layer rests on the sheet) lies flat, centred at x
    uniform in `towel_x_range`, y uniform in +-`towel_max_y`, its long axis turned by a yaw uniform in
    +-`towel_max_yaw`.

    **Success:** folded along the short axis: the particles paired by that fold (`cloth.fold_pairs`
    across the long axis: each row with the row as far from the other short edge, the two short edges
    together) lie, on average, at most `fold_tol` from each other seen from above
    (`cloth.fold_distance(..., top_down=True)`: the two layers keep two particle radii between them,
    which is the cloth's thickness, not a fold error); the towel lies on the table (no particle centre
    higher than `max_height` above it: two layers, a wrinkle allowed, not held up or bunched); and the
    gripper has let go (touches no particle of the towel, `ee.touches`).

    **Level 2:** its Level-1 suite-mates move one part of the object once (FlattenTowelCorner lays
    back one corner of 21-28 particles over at most ~11 cm; DragRopeToGoal drags a rope flat; 150-step
    horizons, demos of 75-85 steps, 2 stages). Here half the sheet (30 of 60 particles) must turn over
    and land on the other half: two corners are pinched and carried ~22.5 cm each, one after the other
    (the second lies where the first carry dragged it, and the sheet slides under the carry), and all 30
    particle pairs count against a 2 cm mean (under the 2.5 cm particle spacing), with a 5.5 cm height
    cap; demos take ~200 steps of a 300-step horizon, 4 stages (pinch and carry, twice):
    T = 10 log10 200 + 4 = 27 against FlattenTowelCorner's 10 log10 84 + 2 = 21.
    """
