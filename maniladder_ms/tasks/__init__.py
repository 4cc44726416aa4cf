"""Every implemented ManiLadder task; importing this registers their env ids."""

from .pick_place_pen import PickPlacePenEnv
from .stack_blocks import StackBlocksEnv
