"""Small batched pose helpers (torch, wxyz quaternions as ManiSkill uses)."""

import torch


def yaw_quat(yaw: torch.Tensor) -> torch.Tensor:
    """(b,) yaw angles -> (b, 4) quaternions of rotations about world z."""
    zeros = torch.zeros_like(yaw)
    return torch.stack([torch.cos(yaw / 2), zeros, zeros, torch.sin(yaw / 2)], dim=1)


def yaw_of(q: torch.Tensor) -> torch.Tensor:
    """(b, 4) quaternions of rotations about z only -> (b,) yaw angles."""
    return 2 * torch.atan2(q[:, 3], q[:, 0])


def actor_yaw(actor) -> float:
    """Yaw of an actor in the first sub-env, for solvers (which drive one env)."""
    return float(yaw_of(actor.pose.q)[0])
