"""Small batched pose helpers (torch, wxyz quaternions as ManiSkill uses)."""

import torch

from mani_skill.utils.geometry.rotation_conversions import (axis_angle_to_quaternion, matrix_to_quaternion, quaternion_apply,
                                                             quaternion_multiply)


def yaw_quat(yaw: torch.Tensor) -> torch.Tensor:
    """(b,) yaw angles -> (b, 4) quaternions of rotations about world z."""
    zeros = torch.zeros_like(yaw)
    return torch.stack([torch.cos(yaw / 2), zeros, zeros, torch.sin(yaw / 2)], dim=1)


def yaw_of(q: torch.Tensor) -> torch.Tensor:
    """(b, 4) quaternions of rotations about z only -> (b,) yaw angles."""
    return 2 * torch.atan2(q[:, 3], q[:, 0])


def face_yaw(q: torch.Tensor, near: float) -> torch.Tensor:
    """(n,) the yaw of a face normal of a body square about z (a cube) with orientation `q` (n, 4): of its four
    side-face normals (90 degrees apart), the one closest to `near`."""
    quarter = torch.pi / 2
    return near + torch.remainder(yaw_of(q) - near + quarter / 2, quarter) - quarter / 2


def matrix_yaw(m: torch.Tensor) -> torch.Tensor:
    """(b, 3, 3) rotation matrices -> (b,) yaw: the angle about world z of the rotated x axis (seen from above)."""
    return torch.atan2(m[:, 1, 0], m[:, 0, 0])


def wrap_angle(a: torch.Tensor) -> torch.Tensor:
    """Angles wrapped into [-pi, pi)."""
    return (a + torch.pi) % (2 * torch.pi) - torch.pi


def tilt(actor) -> torch.Tensor:
    """(num_envs,) angle (rad) between the actor's z axis and the world's."""
    q = actor.pose.q
    # z component of the rotated z axis: 1 - 2 (x^2 + y^2) for a wxyz quaternion
    cos = 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2)
    return torch.arccos(cos.clamp(-1, 1))


def actor_yaw(actor) -> float:
    """Yaw of an actor in the first sub-env, for solvers (which drive one env)."""
    return float(yaw_of(actor.pose.q)[0])


def uprighting(body_q: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
    """(b, 4) orientation `q` (a held object's grasping frame, say a TCP) turned by the world rotation that brings
    the z axis of a body at orientation `body_q` (b, 4) to world z, the shortest way: where a TCP that holds a
    tilted body must turn to stand it upright."""
    z = torch.zeros_like(body_q[:, 1:])
    z[:, 2] = 1
    axis = quaternion_apply(body_q, z)
    c = torch.cross(axis, z, dim=1)
    angle = torch.atan2(c.norm(dim=1), (axis * z).sum(1))
    return quaternion_multiply(axis_angle_to_quaternion(torch.nn.functional.normalize(c, dim=1) * angle[:, None]), q)


def tcp_quat(pointing: torch.Tensor, closing: torch.Tensor) -> torch.Tensor:
    """(n, 4) wxyz quaternions of TCPs whose z axis (out of the palm) is `pointing` and whose fingers close
    along `closing` (the TCP's y axis; made orthogonal to `pointing`); both (n, 3) world directions."""
    z = torch.nn.functional.normalize(pointing, dim=1)
    y = torch.nn.functional.normalize(closing - (closing * z).sum(1, keepdim=True) * z, dim=1)
    return matrix_to_quaternion(torch.stack([torch.cross(y, z, dim=1), y, z], dim=2))


def spaced_xy(b: int, n: int, lo, hi, spacing: float, tries: int = 1000) -> torch.Tensor:
    """(b, n, 2) points uniform in the box [lo, hi] (two (x, y) corners), pairwise at least `spacing` apart:
    rejection sampling, re-drawing one offending point per env and try."""
    lo, hi = torch.tensor(lo), torch.tensor(hi)
    xy = lo + torch.rand(b, n, 2) * (hi - lo)
    for _ in range(tries):
        d = torch.cdist(xy, xy) + torch.eye(n) * 1e3
        bad = (d < spacing).any(dim=2)  # (b, n) points too close to another
        if not bad.any():
            return xy
        first_bad = bad.float().argmax(dim=1)
        rows = bad.any(dim=1).nonzero(as_tuple=True)[0]
        xy[rows, first_bad[rows]] = lo + torch.rand(len(rows), 2) * (hi - lo)
    raise RuntimeError("could not place the points apart; the region is too small")
