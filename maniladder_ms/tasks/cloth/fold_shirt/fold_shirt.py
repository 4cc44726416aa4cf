"""FoldShirt (L3 deformable DG): fold a flat shirt with two grippers, both sleeves in, then the hem onto the collar."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from .base import FoldShirtTask


@register_task("FoldShirt")
class FoldShirtEnv(FoldShirtTask):
    """**Task:** a shirt lies flat on the table; fold it with the two grippers: each arm folds the sleeve on its
    side in over the body, then both take the hem by its corners and lay it onto the collar, and let go.

    **Randomisation:** the shirt (`cloth.shirt()`: a T-shaped single-layer sheet of particles 2.5 cm apart, a body
    of 8 x 6 particles (20 x 15 cm) with a sleeve of 3 x 3 beside its top three rows on each side, 66 particles,
    30 cm across the sleeves, radius 10 mm; `deformables.shirt` says what this proxy can and cannot do) lies flat,
    collar away from the robot at yaw 0, centred at x uniform in `shirt_x_range`, y uniform in +-`shirt_max_y`,
    turned by a yaw uniform in +-`shirt_max_yaw`.

    **Success:** both sleeves in: every particle of each sleeve lies within the body's outline seen from above
    (the rectangle of the body's particle centres plus half a tile, in the body's frame as its collar half lies
    now, `shirt.outline_excess`), give or take `outline_margin` (the sleeve's crease column stands on the body's
    edge, its centre a radius out); the hem on the collar: the top-down distance between each body column's hem
    and collar particles is, on average, at most `hem_tol` (`cloth.fold_distance(..., top_down=True)` over
    `shirt.hem_collar_pairs`); the shirt lies on the table (no particle centre higher than `max_height`: three
    layers where hem, sleeve and body lie on each other); and both grippers have let go (touch no particle,
    `ee.touches`).

    **Level 3:** its Level-2 suite-mates fold a rectangle once (FoldTowelInHalf: half a towel over, 2 carries).
    Here three folds of one sheet in an order (the sleeves first, or the hem would bury them), one sleeve by each
    arm on its side of the body, the third fold by both arms carrying the hem's two corners together 17.5 cm over
    the body onto the collar, on top of the folded sleeves; the rule checks every sleeve particle and every
    hem-collar pair. The 20 demos take 369 steps on average (328-393) of a 500-step horizon, 6 stages:
    T = 10 log10 369 + 6 = 31.7 against FoldTowelInHalf's 27.0.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
