"""Procedural objects shared by ManiLadder tasks, built with ManiSkill's actor builders."""

from .boxes import LiddedBoxShape, build_lidded_box, lid_angle
from .tabletop import build_pen, build_tray

__all__ = ["LiddedBoxShape", "build_lidded_box", "build_pen", "build_tray", "lid_angle"]
