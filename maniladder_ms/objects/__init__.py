"""Procedural objects shared by ManiLadder tasks, built with ManiSkill's actor builders."""

from .tabletop import build_pen, build_tray

__all__ = ["build_pen", "build_tray"]
