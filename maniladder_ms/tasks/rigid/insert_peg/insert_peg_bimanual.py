"""InsertPegBimanual (L2 rigid DG, family InsertPeg): a peg inserted into a block the other arm holds up."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from .base import HeldBlockInsertTask


@register_task("InsertPegBimanual")
class InsertPegBimanualEnv(HeldBlockInsertTask):
    """**Task:** the left arm picks up a block by its handle and holds it up in the air; the right arm picks
    up a square peg standing on the table and inserts it, upright, into the block's blind square hole, then
    lets go of it; the left arm keeps holding the block.

    **Randomisation:**
    - the block (1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth` deep over a
      1 cm floor, and a 12 cm handle as tall as the walls on one side; about 0.24 kg) lies on the left
      half of the table, its handle pointing left (+y) within +-`block_max_yaw` (uniform), the hole's centre
      uniform in x in `block_x_range`, y in `block_y_range`;
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright on the right
      half, its yaw uniform in `peg_yaw_range`, its centre uniform in x in `peg_x_range`, y in `peg_y_range`.

    **Success:** (the InsertPeg family rule, `InsertPegTask`, with the two-arm rows' conditions,
    `HeldBlockInsertTask`) the centre of the peg's lower end, in the
    block's frame, lies at least `insert_depth` below the hole's rim and inside the hole's square opening
    (half side `peg_half` plus half the `clearance`); the peg's axis is within `max_tilt` of the hole's;
    neither gripper holds the peg (`ee.holds`); and the left gripper holds the block (`ee.holds`) with
    the block's origin (the centre of its bottom face under the hole) at least `lift_height` above the table.

    **Level 2:** (against Level 1's HandoverCube: a cube passed between open grippers, put down in a 10 cm
    zone) the peg's lower end must enter a 32 mm opening with 1 mm of play on each side and the peg's yaw
    must match the hole's within about 4 degrees (square in square), 3 cm deep, into a block that hangs from
    the other gripper (it sways and tilts in that grasp, so the insertion follows it); four stages (two
    grasps, lift, insert) with both arms.
    """
