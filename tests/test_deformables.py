"""Deformable proxies: every showcase builds, round-trips its state and stays finite under random
Panda actions; the metrics give the expected values on constructed shapes; clay stays pressed; a
Panda can pick up a rope end and a towel corner (joint and end-effector control); container
decompositions are cached."""

from pathlib import Path

import numpy as np
import pytest
import torch
import gymnasium as gym

import maniladder_ms  # noqa: F401
from maniladder_ms.deformables import clay, cloth, metrics, particles, rope, spool
from maniladder_ms.deformables.showcase import SHOWCASE_ENV_IDS
from maniladder_ms.objects import containers
from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

RANDOM_STEPS = 1000


def _make(kind, **kwargs):
    return gym.make(SHOWCASE_ENV_IDS[kind], obs_mode="state", render_backend="cpu", **kwargs)


@pytest.mark.parametrize("kind", sorted(SHOWCASE_ENV_IDS))
def test_showcase_state_round_trip_and_random_actions(kind):
    env = _make(kind)
    try:
        obs, _ = env.reset(seed=0)
        env.action_space.seed(0)
        base = env.unwrapped
        state = base.get_state_dict()
        for _ in range(5):
            env.step(env.action_space.sample())
        base.set_state_dict(state)
        assert (base.get_obs() - obs).abs().max() < 1e-5
        for _ in range(RANDOM_STEPS):
            obs, *_ = env.step(env.action_space.sample())
        assert torch.isfinite(obs).all()
        points = base.deformable_points()
        assert torch.isfinite(points).all()
        # nothing flew off or fell through the table
        assert points[..., 2].min() > -0.01 and points[..., 2].max() < 1.0
        assert points[..., :2].abs().max() < 1.0
    finally:
        env.close()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="num_envs > 1 needs ManiSkill's GPU sim backend; this machine has no CUDA GPU")
@pytest.mark.parametrize("kind", sorted(SHOWCASE_ENV_IDS))
def test_showcase_batched_on_gpu(kind):
    env = gym.make(SHOWCASE_ENV_IDS[kind], num_envs=2, obs_mode="state", sim_backend="physx_cuda")
    try:
        obs, _ = env.reset(seed=0)
        state = env.unwrapped.get_state_dict()
        for _ in range(20):
            obs, *_ = env.step(env.action_space.sample())
        assert torch.isfinite(obs).all()
        env.unwrapped.set_state_dict(state)
        assert env.unwrapped.deformable_points().shape[0] == 2
    finally:
        env.close()


# ---- rope -----------------------------------------------------------------------------------------
def _polyline(xyz):
    return torch.as_tensor(np.asarray(xyz, dtype=np.float32))[None]


def test_rope_metrics_on_constructed_shapes():
    straight = _polyline([[x, 0, 0] for x in np.linspace(0, 0.4, 22)])
    assert rope.straightness(straight)[0] == pytest.approx(1.0, abs=1e-5)
    assert rope.end_to_end_distance(straight)[0] == pytest.approx(0.4, abs=1e-5)
    t = np.linspace(0, 2 * np.pi * 1.25, 60)
    coil = _polyline(np.stack([0.05 * np.cos(t), 0.05 * np.sin(t), np.zeros_like(t)], axis=1))
    assert rope.winding_number(coil, torch.zeros(2))[0] == pytest.approx(1.25, abs=1e-3)
    assert rope.straightness(coil)[0] < 0.2
    # overhand knot: a trefoil-like curve whose strands alternate over/under
    s = np.linspace(0.2, 2 * np.pi - 0.2, 200)
    trefoil = np.stack([np.sin(s) + 2 * np.sin(2 * s), np.cos(s) - 2 * np.cos(2 * s), -np.sin(3 * s)], axis=1) * 0.03
    assert len(rope.crossings(trefoil)) == 3
    assert rope.is_knotted(trefoil)
    flat_trefoil = trefoil.copy()
    flat_trefoil[:, 2] = np.linspace(0, 0.05, len(s))  # same drawing, each strand lying on the earlier ones
    assert not rope.is_knotted(flat_trefoil)
    assert not rope.is_knotted(straight[0].numpy())


def test_flat_layout_helpers_on_constructed_shapes():
    """`flat_centres`: no turns lay the capsules one segment apart along the heading; a constant turn lays them
    on a circle; `min_self_distance` of a straight rope is two segments (the nearest pair it compares), of a
    hairpin (folded back beside itself) the fold's width."""
    cfg = rope.RopeConfig()
    n, seg = cfg.segments, cfg.segment_length
    straight = rope.flat_centres(torch.zeros(1, n - 1), torch.tensor([np.pi / 2]), seg)
    assert straight[0, :, 0].abs().max() < 1e-6
    assert straight[0, :, 1].tolist() == pytest.approx([k * seg for k in range(n)], abs=1e-5)
    assert rope.min_self_distance(straight)[0] == pytest.approx(2 * seg, abs=1e-5)
    turn = 2 * np.pi / n  # a full circle: the capsule centres on a regular n-gon
    ring = rope.flat_centres(torch.full((1, n - 1), turn), torch.zeros(1), seg)
    radius = seg / 2 / np.sin(turn / 2)  # the circle through the joints; the centres lie cos(turn / 2) of it in
    dist = torch.linalg.norm(ring[0] - ring[0].mean(dim=0), dim=1)
    assert dist.tolist() == pytest.approx([radius * np.cos(turn / 2)] * n, abs=1e-5)
    gap = 0.03
    hairpin = torch.tensor([[[k * seg, 0.0] for k in range(10)]
                            + [[(9 - k) * seg, gap] for k in range(10)]])
    assert rope.min_self_distance(hairpin)[0] == pytest.approx(gap, abs=1e-6)


def test_crumpled_turns_are_crumpled_and_never_overlap():
    """Every crumpled layout (`crumpled_turns`) is at most the asked straightness tip to tip and keeps its
    capsules apart; laid out it spans far less than the rope's length."""
    cfg = rope.RopeConfig()
    torch.manual_seed(0)
    turns = rope.crumpled_turns(200, cfg, 0.6, 0.004)
    assert turns.shape == (200, cfg.segments - 1)
    assert turns.abs().max() <= cfg.max_bend
    points = rope.flat_points(turns, torch.zeros(200), cfg)
    assert (rope.min_self_distance(points[:, 1:-1]) >= 2 * cfg.radius + 0.004).all()
    assert (rope.straightness(points) <= 0.6).all()
    # the polyline's tips lie half a capsule beyond the end capsules' centres, along the end capsules
    assert torch.linalg.norm(points[:, 1] - points[:, 0], dim=1).tolist() == pytest.approx(
        [cfg.segment_length / 2] * 200, abs=1e-5)
    extent = (points[..., :2].amax(dim=1) - points[..., :2].amin(dim=1)).amax(dim=1)
    assert (extent < 0.8 * cfg.length).all()
    with pytest.raises(RuntimeError):
        rope.crumpled_turns(4, cfg, 0.0, 0.004, tries=2)  # nothing is crumpled to a point


def test_winding_number_of_a_rope_laid_once_around_a_post():
    """A rope tied down 11 cm from a post, running straight to the post, once round it (radius 2.3 cm: post
    plus rope radius) and out again beside its standing part: winding number 1 about the post, -1 laid the
    other way round, ~0 about an axis outside the loop; batched, one axis per env."""
    r, d = 0.023, 0.11
    anchor_angle = np.pi / 2
    tangent = anchor_angle - np.arccos(r / d)  # where the straight standing part touches the post
    standing = np.linspace([0, d], [r * np.cos(tangent), r * np.sin(tangent)], 12)
    arc = tangent - np.linspace(0, 2 * np.pi - 2 * (anchor_angle - tangent), 30)[1:]  # clockwise round the post
    wrap = np.stack([r * np.cos(arc), r * np.sin(arc)], axis=1)
    leave = arc[-1]  # leaves the post along the tangent, back out to the anchor's bearing on the far side
    out = wrap[-1] + np.linspace(0, 1, 8)[1:, None] * d * np.array([np.sin(leave), -np.cos(leave)])
    xy = np.concatenate([standing, wrap, out])
    laid = np.concatenate([xy, np.full((len(xy), 1), 0.008)], axis=1)
    mirrored = laid * np.array([-1, 1, 1])
    points = torch.as_tensor(np.stack([laid, mirrored, laid]), dtype=torch.float32)
    axes = torch.tensor([[0.0, 0.0], [0.0, 0.0], [0.3, 0.0]])
    turns = rope.winding_number(points, axes)
    assert turns[0] == pytest.approx(-1.0, abs=0.02)
    assert turns[1] == pytest.approx(1.0, abs=0.02)
    assert abs(turns[2]) < 0.1
    # the same rope only laid beside the post (straight past it) does not wind once
    beside = _polyline([[x, 0.03, 0.008] for x in np.linspace(-0.2, 0.2, 22)])
    assert abs(rope.winding_number(beside, torch.zeros(2))[0]) < 0.5

    # wound_around: the same turns; wound once (either way round), and below a top above the rope only
    turns, wound, below = rope.wound_around(points, axes, 1.0, 0.05)
    assert torch.equal(turns, rope.winding_number(points, axes))
    assert wound.tolist() == [True, True, False] and below.all()
    lifted = points.clone()
    lifted[0, 20, 2] = 0.06  # one point of the first rope over the top
    assert rope.wound_around(lifted, axes, 1.0, 0.05)[2].tolist() == [False, True, True]

def test_rope_in_groove_fraction():
    """A 20-capsule rope laid along a groove's axis inside it counts 1.0; laid beside it (parallel, outside
    the walls) 0; half of it inside and the other half past the groove's end 0.5; lying on the walls' top (above
    it) 0; batched, one groove per env, the grooves turned and moved."""
    half_width, half_length, top = 0.011, 0.23, 0.019
    s = np.linspace(-0.19, 0.19, 20)
    yaw = np.deg2rad(100.0)
    along, across = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
    centre = np.array([0.05, -0.02])

    def laid(offset_along, offset_across, z):
        xy = centre + (s[:, None] + offset_along) * along + offset_across * across
        return np.concatenate([xy, np.full((len(s), 1), z)], axis=1)

    ropes = [laid(0, 0.002, 0.012), laid(0, 0.03, 0.008), laid(0.23, 0, 0.012), laid(0, 0.0, 0.027)]
    points = torch.as_tensor(np.stack(ropes), dtype=torch.float32)
    centres = torch.as_tensor(np.tile(centre, (4, 1)), dtype=torch.float32)
    fraction = metrics.inside_channel_fraction(points, centres, torch.full((4,), yaw), half_width, half_length, top)
    assert fraction.tolist() == pytest.approx([1.0, 0.0, 0.5, 0.0])
    # the same ropes against a groove turned 90 degrees: none runs along it
    turned = metrics.inside_channel_fraction(points, centres, torch.full((4,), yaw + np.pi / 2), half_width,
                                             half_length, top)
    assert (turned <= 0.1).all()


def test_channel_coords():
    """Points placed at known distances along and across a turned, moved channel's axis read those distances back
    (across: left of the axis positive), batched over two channels."""
    yaws = torch.tensor([0.3, -2.0])
    centres = torch.tensor([[0.05, -0.02, 0.0], [-0.1, 0.04, 0.0]])
    offsets = torch.tensor([[0.03, 0.004], [-0.02, -0.009], [0.0, 0.0]])  # (along, across)
    c, s = torch.cos(yaws)[:, None], torch.sin(yaws)[:, None]
    x = centres[:, None, 0] + offsets[:, 0] * c - offsets[:, 1] * s
    y = centres[:, None, 1] + offsets[:, 0] * s + offsets[:, 1] * c
    points = torch.stack([x, y, torch.full_like(x, 0.01)], dim=-1)
    along, across = metrics.channel_coords(points, centres, yaws)
    assert torch.allclose(along, offsets[:, 0].expand(2, 3), atol=1e-6)
    assert torch.allclose(across, offsets[:, 1].expand(2, 3), atol=1e-6)


def test_rope_through_ring():
    """A ring standing upright (axis along x, 3 cm inner radius) at a different place per env: a 40 cm rope along
    its axis through its centre, 14.9 cm on one side, counts one crossing with 14.9 cm on the shorter side; the same
    rope 5 cm to the side of the ring (past it, outside the disc) none; a rope threaded through and back (a
    hairpin, its bend 10 cm past the ring) two crossings; a rope through the ring's plane but across the ring's
    rim (4 cm off the centre) none."""
    centres = torch.tensor([[0.0, 0.0, 0.05], [0.1, -0.05, 0.06], [0.0, 0.1, 0.05], [-0.05, 0.0, 0.05]])
    normal = torch.tensor([1.0, 0.0, 0.0]).expand(4, 3)
    x = torch.linspace(-0.15, 0.25, 21) + 0.001  # 2 cm segments, the ring's plane between points (none on it)

    def line(centre, dy, dz):
        return torch.stack([centre[0] + x, torch.full_like(x, centre[1] + dy), torch.full_like(x, centre[2] + dz)],
                           dim=1)

    straight = line(centres[0], 0.0, 0.0)
    beside = line(centres[1], 0.05, 0.0)
    out_x = centres[2, 0] + torch.linspace(-0.149, 0.101, 11)  # 11 points out, the bend at 10 cm past the ring
    hairpin = torch.cat([torch.stack([out_x, torch.full_like(out_x, centres[2, 1] + 0.01),
                                      torch.full_like(out_x, centres[2, 2])], dim=1),
                         torch.stack([out_x.flip(0), torch.full_like(out_x, centres[2, 1] - 0.01),
                                      torch.full_like(out_x, centres[2, 2])], dim=1)])[:21]
    rim = line(centres[3], 0.0, 0.04)
    points = torch.stack([straight, beside, hairpin, rim])
    count, shorter = rope.through_ring(points, centres, normal, 0.03)
    assert count.tolist() == [1, 0, 2, 0]
    assert shorter[0] == pytest.approx(0.149, abs=1e-4)  # from its first point, 1 mm short of 15 cm, to the ring
    assert shorter[1] == 0 and shorter[3] == 0
    assert shorter[2] > 0.1  # the hairpin's arms: ~25 cm of rope before its first crossing and after its last


def test_rope_built_straight_is_straight():
    env = _make("rope")
    try:
        env.reset(seed=0)
        r = env.unwrapped.rope
        b = torch.zeros(1, 2 * (r.config.segments - 1))
        r.set_shape(Pose.create_from_pq(torch.tensor([[0.0, -0.2, r.config.radius]])), b)
        points = r.points()
        assert rope.straightness(points)[0] == pytest.approx(1.0, abs=1e-4)
        assert rope.end_to_end_distance(points)[0] == pytest.approx(r.config.length, abs=1e-4)
        # laid flat in a constant curve: an arc centred where asked, on the table
        r.lay_flat(torch.tensor([[0.05, -0.1]]), torch.tensor([0.3]), torch.full((1, r.config.segments - 1), 0.15))
        centres = r.points()[0, 1:-1]
        assert centres[:, :2].mean(dim=0).tolist() == pytest.approx([0.05, -0.1], abs=1e-4)
        assert centres[:, 2].tolist() == pytest.approx([r.config.radius] * r.config.segments, abs=1e-5)
        assert rope.straightness(r.points())[0] < 0.8
    finally:
        env.close()


def test_panda_picks_up_a_rope_end():
    from maniladder_ms.solvers.panda import PandaSolver

    env = _make("rope", control_mode="pd_joint_pos")
    try:
        with PandaSolver.episode(env, seed=0) as robot:
            r = env.unwrapped.rope
            first = r.links[0].pose
            axis = rope.segment_axis(first.q)[0].numpy()
            yaw = robot.closest_grasp_yaw(float(np.arctan2(axis[1], axis[0])) + np.pi / 2)
            grip_at = r.links[1].pose.p[0].numpy()  # the second capsule's middle, clear of the joints
            robot.pick(robot.top_down_pose([grip_at[0], grip_at[1], r.config.radius], yaw), lift_height=0.15)
            for _ in range(3):  # hold still while the rope stops swinging: it stays in the grip
                robot.grip(closed=True, steps=20)
                points = r.points()[0]
                assert torch.isfinite(points).all()
                assert points[:3, 2].min() > 0.08  # the gripped end is up in the air
                assert points[-1, 2] < 0.03  # the rest still trails on the table
    finally:
        env.close()


def test_leap_hand_scissor_pinches_a_rope():
    """The LEAP hand takes the middle capsule of a rope lying on the table between its straight index and
    middle fingers (the "scissor" pinch: the only LEAP pinch whose contacts reach down to a 1.6 cm rope's
    middle height), lifts it 28 cm and holds it 60 steps: a friction grasp only."""
    from maniladder_ms.solvers.driven import DrivenSolver
    from maniladder_ms.solvers.rope.lift_rope_hand import pinch_and_lift

    env = gym.make("ManiLadder-LiftRopeHand-v1", obs_mode="state", control_mode="pd_ee_delta_pose")
    try:
        with DrivenSolver.episode(env, seed=0) as s:
            task = env.unwrapped
            pinch_and_lift(s, task)
            for _ in range(3):
                for _ in range(20):
                    s.step()
                points = task.rope.points()[0]
                assert torch.isfinite(points).all()
                assert bool(s.info["is_grasped"][0])  # still between index and middle finger
                assert float(s.info["lifted_fraction"][0]) >= 0.8  # and up in the air
    finally:
        env.close()


# ---- cloth ----------------------------------------------------------------------------------------
def _box_aside(base):
    """Move the towel showcase's box off the towel, so the towel can lie flat."""
    base.box.set_pose(Pose.create_from_pq(torch.tensor([[0.05, 0.3, 0.03]])))


@pytest.mark.parametrize("corner", range(4))
def test_panda_picks_up_a_towel_corner(corner):
    """A Panda pinches a corner particle of the draped towel (fingers closing across the corner's
    diagonal, off by up to 0.3 rad and 3 mm), lifts it 15 cm and holds it: a friction grasp only."""
    import sapien
    from maniladder_ms.solvers.panda import PandaSolver

    rng = np.random.default_rng(corner)
    env = _make("towel", control_mode="pd_joint_pos")
    try:
        with PandaSolver.episode(env, seed=corner) as robot:
            c = env.unwrapped.cloth
            robot.grip(closed=False, steps=20)  # the towel settles over its box
            i = c.layout.named["corners"][corner]
            points = c.positions()[0].numpy()
            outward = points[i, :2] - points[:, :2].mean(axis=0)
            yaw = float(np.arctan2(outward[1], outward[0])) + np.pi / 2 + rng.uniform(-0.3, 0.3)
            at = points[i] + np.append(rng.uniform(-0.003, 0.003, 2), 0.0)
            grasp = robot.top_down_pose(at, robot.closest_grasp_yaw(yaw))
            robot.pick(grasp, lift_height=0.15)
            gap = env.unwrapped.agent.robot.get_qpos()[0, -2:].sum().item()
            assert gap > 1.5 * c.config.radius  # the fingers stop on the particle, not deep inside it
            for _ in range(3):  # hold 60 steps
                robot.grip(closed=True, steps=20)
                points = c.positions()[0]
                assert torch.isfinite(points).all()
                tcp = env.unwrapped.agent.tcp.pose.p[0]
                assert torch.linalg.norm(points[i] - tcp) < 0.015  # the corner is still between the fingers
                assert points[i, 2] > 0.13  # and up in the air
                assert points[:, 2].min() < 0.02  # the far side still lies on the table
    finally:
        env.close()


@pytest.mark.parametrize("corner", range(4))
def test_ee_delta_gripper_picks_up_a_flat_towel_corner(corner):
    """The same pinch with pd_ee_delta_pose (DrivenSolver) on the towel lying flat: the fingers open
    only to a 4 cm gap before coming down (fully open, 8 cm, a finger lands on the corner's
    neighbours and stops the hand 1.5 cm short: 4/8 missed), close, lift 15 cm, hold 60 steps."""
    from maniladder_ms.solvers.control import top_down_quat
    from maniladder_ms.solvers.driven import DrivenSolver

    rng = np.random.default_rng(corner)
    env = _make("towel", control_mode="pd_ee_delta_pose")
    try:
        with DrivenSolver.episode(env, seed=corner) as s:
            base, c = env.unwrapped, env.unwrapped.cloth
            _box_aside(base)
            c.set_rest_shape(Pose.create_from_pq(torch.tensor([[0.05, 0.0, c.config.radius]])))
            s.release("gripper", steps=5)
            i = c.layout.named["corners"][corner]
            points = c.positions()[0]
            outward = points[i, :2] - points[:, :2].mean(dim=0)
            yaw = float(torch.atan2(outward[1], outward[0])) + np.pi / 2 + rng.uniform(-0.3, 0.3)
            at = (points[i] + torch.tensor([*rng.uniform(-0.003, 0.003, 2), 0.0], dtype=torch.float32))[None]
            q = top_down_quat(DrivenSolver.neutral_yaw(torch.tensor([yaw]), np.pi), 1, device=at.device)
            s.set_ee("gripper", [0.2], steps=1)  # fingers 4 cm apart: around the corner particle only
            s.move({"arm": (s.above(at, 0.1), q)}, max_steps=60)
            s.move({"arm": (s.above(at, 0.03), q)}, max_steps=40)
            s.move({"arm": (at, q)}, max_steps=80, pos_tol=0.002)
            s.grasp("gripper")
            s.move({"arm": (s.above(at, 0.15), q)}, max_steps=40)
            assert base.agent.robot.get_qpos()[0, -2:].sum().item() > 1.5 * c.config.radius
            for _ in range(3):  # hold 60 steps
                s.grip(True, "gripper", steps=20)
                points = c.positions()[0]
                assert torch.isfinite(points).all()
                assert torch.linalg.norm(points[i] - base.agent.tcp.pose.p[0]) < 0.03  # between the pads
                assert points[i, 2] > 0.13
                assert points[:, 2].min() < 0.02
    finally:
        env.close()


@pytest.mark.parametrize("seed", range(2))
def test_folded_towel_corner_stays_on_top_and_a_panda_unfolds_it(seed, monkeypatch):
    """A towel lying flat with a corner folded over (21 of 100 particles, `cloth.fold_corner`): the folded
    layer rests on the sheet (it does not sink through it: particles of radius 10 mm, see ClothConfig)
    and stays folded, and a Panda pinching the folded corner particle from above and laying it at its
    flat position covers the flat towel's area again."""
    from maniladder_ms.deformables.showcase import TowelShowcaseEnv
    from maniladder_ms.solvers.panda import PandaSolver

    monkeypatch.setattr(TowelShowcaseEnv, "cloth_config", cloth.ClothConfig(radius=0.010))

    rng = np.random.default_rng(seed)
    env = _make("towel", control_mode="pd_joint_pos")
    try:
        with PandaSolver.episode(env, seed=seed) as robot:
            base, c = env.unwrapped, env.unwrapped.cloth
            _box_aside(base)
            r, spacing = c.config.radius, c.config.spacing
            local, q = cloth.fold_corner(c.layout, 10, 10, 6, gap=2.2 * r)
            offset = np.array([0.05, 0.0, r])
            c.place(torch.tensor(local + offset, dtype=torch.float32), torch.tensor(q, dtype=torch.float32))
            robot.grip(closed=False, steps=20)
            points = c.positions()
            assert cloth.coverage(points, c.layout, spacing)[0] == pytest.approx(0.86, abs=0.02)
            rows, cols = np.divmod(np.arange(100), 10)
            assert points[0, rows + cols < 4, 2].min() > 1.8 * r  # the folded layer lies on the sheet
            corner = points[0, 0].numpy()
            goal = c.layout.positions[0] + offset
            d = goal[:2] - corner[:2]
            yaw = robot.closest_grasp_yaw(float(np.arctan2(d[1], d[0])) + np.pi / 2 + rng.uniform(-0.2, 0.2))
            robot.pick(robot.top_down_pose(corner + [0, 0, 0.006], yaw), lift_height=0.04)
            robot.move(robot.top_down_pose(goal + [0, 0, 0.04], yaw))
            robot.move(robot.top_down_pose(goal + [0, 0, 0.005], yaw))
            robot.grip(closed=False)
            robot.move(robot.top_down_pose(goal + [0, 0, 0.06], yaw))
            points = c.positions()
            assert torch.isfinite(points).all()
            assert cloth.coverage(points, c.layout, spacing)[0] > 0.95
    finally:
        env.close()


def assert_drives_at_rest(layout, positions, quats):
    """Every link's two drive frames (at the rest midpoint, in each particle's frame) meet at one point in the
    sheet laid at `positions` [N, 3] turned by `quats` [N, 4] (wxyz)."""
    from scipy.spatial.transform import Rotation

    turned = Rotation.from_quat(np.roll(quats, -1, axis=1))  # scipy: xyzw
    for i, j in layout.links:
        mid = (layout.positions[i] + layout.positions[j]) / 2
        frame_i = positions[i] + turned[i].apply(mid - layout.positions[i])
        frame_j = positions[j] + turned[j].apply(mid - layout.positions[j])
        assert np.linalg.norm(frame_i - frame_j) < 1e-9


@pytest.mark.parametrize("corner", range(4))
def test_fold_corner_leaves_every_drive_at_rest(corner):
    """Every link's two drive frames meet at one point in a folded towel (no drive pulls at the start),
    no two unlinked particles of 10 mm overlap, the folded particles are those near `corner`, and the
    layer lies `gap` above the sheet."""
    layout, r = cloth.towel(10, 10), 0.010
    positions, quats = cloth.fold_corner(layout, 10, 10, 6, gap=2.2 * r, corner=corner)
    assert_drives_at_rest(layout, positions, quats)
    linked = set(layout.links)
    gaps = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
    assert min(gaps[i, j] for i in range(100) for j in range(i + 1, 100) if (i, j) not in linked) > 2 * r
    moved = np.linalg.norm(positions - layout.positions, axis=1) > 1e-9
    assert moved.sum() == 21 and moved[layout.named["corners"][corner]]
    assert positions[layout.named["corners"][corner], 2] == pytest.approx(2.2 * r)


def test_cloth_coverage_ignores_the_towel_yaw():
    spacing = 0.025
    layout = cloth.towel(10, 10, spacing)
    for k, cells in enumerate((6, 7)):
        folded, _ = cloth.fold_corner(layout, 10, 10, cells, gap=0.022, corner=k)
        for yaw in (0.0, 0.4, -0.7, 2.0):
            turn = torch.tensor([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]], dtype=torch.float32)
            shapes = torch.tensor(np.stack([layout.positions, folded]), dtype=torch.float32) @ turn.T + torch.tensor([0.1, -0.2, 0.01])
            assert cloth.grid_yaw(shapes, layout.links)[0] == pytest.approx((yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4, abs=1e-5)
            flat, fold = cloth.coverage(shapes, layout, spacing).tolist()
            assert flat == pytest.approx(1.0, abs=1e-5)
            assert fold < 0.9


def test_cloth_metrics_flat_and_folded():
    spacing = 0.025
    layout = cloth.towel(10, 10, spacing)
    flat = torch.as_tensor(layout.positions, dtype=torch.float32)[None]
    assert metrics.footprint_area(flat, spacing)[0] == pytest.approx(100 * spacing**2, rel=1e-4)
    assert cloth.flatness(flat)[0] < 1e-6
    pairs = cloth.fold_pairs(10, 10, axis=0)
    assert cloth.fold_distance(flat, pairs)[0] > 0.1
    folded = flat.clone()  # rows 5..9 mirrored onto rows 0..4, one layer up
    top = folded[0, :, 0] > 0
    folded[0, top, 0] = -folded[0, top, 0]
    folded[0, top, 2] += 0.016
    assert cloth.fold_distance(folded, pairs)[0] == pytest.approx(0.016, abs=1e-5)
    assert metrics.footprint_area(folded, spacing)[0] == pytest.approx(50 * spacing**2, rel=1e-4)
    region = (-0.125, 0.125, -0.125, 0.125)
    assert metrics.region_coverage(flat, spacing, region)[0] == pytest.approx(1.0)
    assert metrics.region_coverage(folded, spacing, region)[0] == pytest.approx(0.5)
    hanging = flat.clone()
    x = hanging[0, :, 0]
    hanging[0, :, 2] = 0.31 - (x - x.min())  # hung by its -x edge over a bar at z = 0.3
    assert cloth.fraction_below(hanging, 0.3)[0] == pytest.approx(0.9)
    assert cloth.fraction_beyond(flat, torch.zeros(3), torch.tensor([1.0, 0, 0]))[0] == pytest.approx(0.5)


def test_hanging_fractions_of_a_towel_draped_over_a_bar_and_lying_flat():
    """`cloth.hanging_fractions` on constructed 10 x 8 towels (HangTowelOnBar's) beside a bar along y with its
    axis at x = 0.05, top 0.2 m up: draped symmetrically over it (rows 0-3 hanging on the -x side, rows 4-5 on
    top, rows 6-9 hanging on the +x side) gives 40% / 40%; lying flat on the table on the -x side gives 1 / 0;
    the same drape shifted by two rows to the +x side 20% / 60%; batched over the three."""
    spacing, rows, cols = 0.025, 10, 8
    layout = cloth.towel(rows, cols, spacing)
    r, c = np.divmod(np.arange(rows * cols), cols)
    y = layout.positions[:, 1]

    def draped(shift):
        rr = r + shift  # rows that hang on the -x side: rr < 4; on top: 4, 5; +x side: rr > 5
        x = np.where(rr < 4, 0.05 - 0.02, np.where(rr > 5, 0.05 + 0.02, 0.05 + (rr - 4.5) * 0.02))
        z = np.where(rr < 4, 0.2 - (4 - rr) * spacing, np.where(rr > 5, 0.2 - (rr - 5) * spacing, 0.21))
        return np.stack([x, y, z], axis=1)

    flat = layout.positions + np.array([-0.1, 0.0, 0.01])
    points = torch.tensor(np.stack([draped(0), flat, draped(2)]), dtype=torch.float32)
    bar = torch.tensor([[0.05, 0.0, 0.19]] * 3)
    sides = cloth.hanging_fractions(points, bar, torch.tensor([0.0, 1.0, 0.0]), 0.2)
    assert sides[0].tolist() == pytest.approx([0.4, 0.4])
    assert sides[1].tolist() == pytest.approx([1.0, 0.0])
    assert sides[2].tolist() == pytest.approx([0.2, 0.6])
    # the bar turned end for end (axis along -y): the sides swap
    swapped = cloth.hanging_fractions(points, bar, torch.tensor([0.0, -1.0, 0.0]), torch.full((3,), 0.2))
    assert torch.allclose(swapped[:, [1, 0]], sides)


def test_towel_loop_built_round_a_hook_is_on_it_and_one_beside_it_is_not():
    """`cloth.towel_with_loop`'s corner loop, its ring turned upright across a wall hook (a shaft along -x out of a
    wall, 6 cm long, tip at the origin) and centred on the shaft 1.5 cm behind the tip: `cloth.loop_on_hook` and
    a winding of one turn; the same loop 5 cm beside the shaft (no turn), 3 cm in front of the tip (one turn
    round the shaft's line, but off the hook) and lying flat on the table under it (no turn): not on the hook;
    batched over the four."""
    layout = cloth.towel_with_loop(10, 8, 7)
    ring = layout.named["loop"]
    assert len(ring) == 8 and layout.named["loop"][0] == layout.named["corners"][3]
    # every link, ring ones too, one spacing long at rest
    lengths = [np.linalg.norm(layout.positions[a] - layout.positions[b]) for a, b in layout.links]
    assert np.allclose(lengths, 0.025)
    local = layout.positions - layout.positions[ring].mean(axis=0)  # the ring's centre at the origin

    def turned(rotation, centre):
        return local @ np.asarray(rotation, dtype=float).T + np.asarray(centre)

    upright = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # the sheet's z (the ring's normal) along the shaft (x)
    shapes = [turned(upright, [0.015, 0, 0]), turned(upright, [0.015, 0.05, 0]), turned(upright, [-0.03, 0, 0]),
              local + np.array([0.0, 0.0, -0.15])]
    points = torch.tensor(np.stack(shapes), dtype=torch.float32)
    tip, axis = torch.zeros(4, 3), torch.tensor([-1.0, 0.0, 0.0])
    winding = cloth.loop_winding(points, ring, tip, axis)
    assert winding[0].abs().item() == pytest.approx(1.0, abs=1e-4)
    assert winding[1].abs().item() == pytest.approx(0.0, abs=1e-4)
    assert winding[2].abs().item() == pytest.approx(1.0, abs=1e-4)
    assert cloth.loop_on_hook(points, ring, tip, axis, 0.06).tolist() == [True, False, False, False]


def test_top_down_fold_distance_of_a_towel_folded_in_half_along_its_short_axis():
    """`cloth.fold_distance(..., top_down=True)` on a 10 x 6 towel (FoldTowelInHalf's) folded in half by
    construction (`cloth.fold_edge` at its middle row, the folded rows shifted to lie right over their
    partners): 0 seen from above, while the full distance is the layers' gap; flat it is the mean
    mirrored distance; folded along the long axis instead (columns paired) the short-axis pairs stay apart."""
    spacing, rows, cols = 0.025, 10, 6
    layout = cloth.towel(rows, cols, spacing)
    pairs = cloth.fold_pairs(rows, cols, axis=0)
    assert len(pairs) == 30 and (0, 54) in pairs and (29, 35) in pairs  # row k with row 9 - k
    flat = torch.as_tensor(layout.positions, dtype=torch.float32)[None]
    # flat: pairs (k, 9 - k) lie (9 - 2k) spacings apart, mean over k = 0..4: 5 spacings
    assert cloth.fold_distance(flat, pairs, top_down=True)[0] == pytest.approx(5 * spacing, abs=1e-6)
    folded, _ = cloth.fold_edge(layout, rows, cols, rows // 2)  # rows 0-3 turned over, row 4 in the crease
    folded = torch.as_tensor(folded, dtype=torch.float32)
    r = torch.arange(rows * cols) // cols
    folded[r < rows // 2 - 1, 0] += spacing  # fold_edge lays row 3 over row 5: shift the layer onto its partners
    folded[r == rows // 2 - 1, 0] += spacing / 2  # and the crease row over row 5, half a spacing up
    folded = folded[None]
    assert cloth.fold_distance(folded, pairs, top_down=True)[0] == pytest.approx(0.0, abs=1e-6)
    full = cloth.fold_distance(folded, pairs)[0]  # the two layers one spacing apart (crease half of it)
    assert full == pytest.approx((4 * spacing + spacing / 2) / 5, abs=1e-6)
    lengthwise = flat.clone()  # folded along the long axis: columns 3-5 over columns 0-2
    right = lengthwise[0, :, 1] > 0
    lengthwise[0, right, 1] = -lengthwise[0, right, 1]
    lengthwise[0, right, 2] += 0.02
    assert cloth.fold_distance(lengthwise, pairs, top_down=True)[0] == pytest.approx(5 * spacing, abs=1e-6)
    assert cloth.fold_distance(lengthwise, cloth.fold_pairs(rows, cols, axis=1), top_down=True)[0] < 1e-6


def test_diagonal_fold_pairs_of_a_napkin_folded_diagonally():
    """`cloth.diagonal_fold_pairs` on an 8 x 8 napkin (FoldNapkinHands'): 28 pairs per diagonal, opposite corners
    together; a napkin folded along either diagonal by construction (each particle off the fold line mirrored onto
    its partner, one layer higher) has top-down fold distance 0 for that diagonal and not for the other; flat, both
    diagonals give the mean mirrored distance; the top layer nested in the bottom layer's hollows (shifted half a
    cell along both grid axes) gives half a cell's diagonal."""
    spacing, size = 0.025, 8
    layout = cloth.towel(size, size, spacing)
    main, anti = cloth.diagonal_fold_pairs(size), cloth.diagonal_fold_pairs(size, anti=True)
    assert len(main) == len(anti) == size * (size - 1) // 2
    corners = layout.named["corners"]  # (-x,-y), (-x,+y), (+x,-y), (+x,+y)
    assert (corners[1], corners[2]) in main and (corners[0], corners[3]) in anti
    flat = torch.as_tensor(layout.positions, dtype=torch.float32)
    # flat: a pair on diagonal line k (k cells off the fold line) lies k * spacing * sqrt 2 apart
    expected = np.mean([k * spacing * np.sqrt(2) for k in range(1, size) for _ in range(size - k)])
    for pairs in (main, anti):
        assert cloth.fold_distance(flat[None], pairs, top_down=True)[0] == pytest.approx(expected, abs=1e-6)
    for pairs, other in ((main, anti), (anti, main)):
        folded = flat.clone()
        for i, j in pairs:  # particle i over its partner j, one layer up
            folded[i] = flat[j] + torch.tensor([0.0, 0.0, 0.02])
        folded = folded[None]
        assert cloth.fold_distance(folded, pairs, top_down=True)[0] == pytest.approx(0.0, abs=1e-6)
        assert cloth.fold_distance(folded, pairs)[0] == pytest.approx(0.02, abs=1e-6)  # the layers' gap
        assert cloth.fold_distance(folded, other, top_down=True)[0] > 0.05
        nested = folded.clone()
        top = [i for i, _ in pairs]
        nested[0, top, :2] += spacing / 2
        assert cloth.fold_distance(nested, pairs, top_down=True)[0] == pytest.approx(spacing / np.sqrt(2), abs=1e-6)


def test_fold_edge_keeps_every_link_at_rest_length():
    """`cloth.fold_edge`: the drive frames of every linked pair meet (they sit at the rest midpoint in each
    particle's frame), the folded rows lie one spacing above the sheet, upside down, and the footprint
    shrinks by the folded rows and the crease."""
    spacing = 0.025
    layout = cloth.towel(10, 10, spacing)
    positions, quats = cloth.fold_edge(layout, 10, 10, 4)
    assert_drives_at_rest(layout, positions, quats)
    rows = np.arange(100) // 10
    assert np.allclose(positions[rows < 3, 2], spacing)  # 3 rows on top
    assert np.allclose(positions[rows == 2, 0], positions[rows == 4, 0])  # right above row 4
    assert np.allclose(positions[rows >= 4], layout.positions[rows >= 4])
    area = metrics.footprint_area(torch.as_tensor(positions, dtype=torch.float32)[None], spacing)[0]
    assert area / (100 * spacing**2) == pytest.approx(0.65, abs=0.03)  # 6.5 of 10 rows' length left


def test_target_coverage_per_env_rectangle():
    spacing = 0.025
    flat = torch.as_tensor(cloth.towel(10, 10, spacing).positions, dtype=torch.float32)[None].repeat(3, 1, 1)
    centre = torch.tensor([[0.0, 0.0], [0.05, 0.0], [0.0, 0.0]])
    lifted = flat.clone()
    lifted[2, :50, 2] = 0.1  # half the towel lifted off the table
    coverage = metrics.target_coverage(torch.stack([flat[0], flat[1], lifted[2]]), spacing, centre, (0.125, 0.125),
                                       max_height=0.03)
    assert coverage.tolist() == pytest.approx([1.0, 0.8, 0.5])


def test_cloth_layouts():
    shirt = cloth.shirt()
    assert len(shirt.positions) == 8 * 6 + 2 * 9
    assert set(shirt.named["left_sleeve"]).isdisjoint(shirt.named["right_sleeve"])
    bag = cloth.bag(6, 6, 5)
    assert len(bag.positions) == 2 * 36 + 2 * 5
    seams = [(i, j) for i, j in bag.links if j == i + 36]
    assert len(seams) == 6 + 6 + 4  # both sides and the bottom between the corners
    assert len(cloth.tent_panel().named["grommets"]) == 4
    towel = cloth.towel(10, 8)  # particle r * 8 + c at row r, column c
    assert [towel.neighbours(i) for i in towel.named["corners"]] == [[1, 8], [6, 15], [64, 73], [71, 78]]
    assert towel.neighbours(9) == [1, 8, 10, 17]


# ---- clay -----------------------------------------------------------------------------------------
def test_clay_metrics():
    spacing, r = 0.012, 0.0058
    block = torch.as_tensor(clay.clay_block((0.03, 0.03, 0.012), spacing), dtype=torch.float32)[None]
    assert clay.height(block, r)[0] == pytest.approx(2 * spacing + 2 * r, abs=1e-5)
    assert clay.width_along(block, torch.tensor([1.0, 0.0]), r)[0] == pytest.approx(4 * spacing + 2 * r, abs=1e-5)
    top = clay.surface_height_at(block, torch.zeros(2), 0.01, r)
    dented = block.clone()
    centre = torch.linalg.norm(dented[0, :, :2], dim=-1) < 0.001
    dented[0, centre & (dented[0, :, 2] > 0.02), 2] -= 0.012
    assert clay.dent_depth(dented, torch.zeros(2), top, 0.005, r)[0] == pytest.approx(0.012, abs=1e-5)
    region = (-0.036, 0.036, -0.036, 0.036)
    target = metrics.footprint_grid(block, spacing, region)
    assert metrics.iou(target, target)[0] == 1
    shifted = block + torch.tensor([0.024, 0, 0])
    assert 0.3 < metrics.iou(metrics.footprint_grid(shifted, spacing, region), target)[0] < 0.7
    voxels = metrics.voxel_grid(block, spacing, region + (-0.01, 0.04))
    assert metrics.iou(voxels, voxels)[0] == 1


def test_star_outline_and_imprint_iou():
    outer, inner, arms = 0.05, 0.028, 5
    tips = outer * 0.99 * torch.tensor([[np.cos(a), np.sin(a)] for a in np.arange(arms) * 2 * np.pi / arms])
    valleys_out = inner * 1.05 * torch.tensor([[np.cos(a), np.sin(a)] for a in (np.arange(arms) + 0.5) * 2 * np.pi / arms])
    assert metrics.inside_star(tips, outer, inner, arms).all()
    assert not metrics.inside_star(valleys_out, outer, inner, arms).any()
    assert metrics.inside_star(torch.zeros(1, 2), outer, inner, arms).all()
    assert not metrics.inside_star(torch.tensor([[0.0, outer * 1.01]]), outer, inner, arms).any()
    spacing = 0.012
    start = torch.as_tensor(clay.clay_block((0.048, 0.048, 0.012), spacing), dtype=torch.float32)[None].repeat(2, 1, 1)
    centre, yaw = torch.tensor([0.004, -0.003]), 0.3

    def under(at):  # particles whose start xy lies under the star centred at `at`, turned by `yaw`
        rel = start[..., :2] - at
        c, s = np.cos(yaw), np.sin(yaw)
        return metrics.inside_star(torch.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1]], -1),
                                   outer, inner, arms)

    target = under(centre)
    top = clay.top_layer(start, spacing)
    assert top[0].sum() == 81 and 20 < (top & target)[0].sum() < 40
    dented = start.clone()
    dented[0, :, 2] -= 0.008 * (top & target)[0]  # env 0: the star's cells pressed 8 mm, a star-shaped dent
    dented[1, :, 2] -= 0.008 * (top & under(centre + torch.tensor([0.04, 0.0])))[1]  # env 1: the dent 4 cm off
    iou = clay.imprint_iou(start, dented, target, 0.005, spacing)
    assert iou[0] == pytest.approx(1.0)
    assert iou[1] < 0.3
    shallow = clay.imprint_iou(start, dented, target, 0.009, spacing)  # not deep enough: nothing counts
    assert (shallow == 0).all()
    flat = start.clone()
    flat[..., 2] -= 0.008 * top  # the whole top pressed down: the star's cells are a minority of the sunk ones
    assert (clay.imprint_iou(start, flat, target, 0.005, spacing) < 0.5).all()


def test_cup_depth_on_constructed_clay():
    """A cup's depth (`clay.cup_depth`): a cup built by construction (a ring of walls three layers high round a floor
    one layer thick) is as deep as its walls stand over its floor, wherever it stands and however it is turned; the
    untouched ball, the cup with one side's wall taken away (a "C"), a dent open on a side, a flattened disk and a ring
    without a floor are no cup."""
    spacing, r = 0.012, 0.0058
    floor_within, wall_within, arc = 0.007, 0.04, np.radians(60)
    block = torch.as_tensor(clay.clay_block((0.024, 0.024, 0.024), spacing), dtype=torch.float32)  # 5 x 5 x 5
    ij = torch.round(block / spacing)

    def depth(points: torch.Tensor) -> float:
        return float(clay.cup_depth(points[None], r, floor_within, wall_within, arc)[0])

    middle = (ij[:, 0].abs() <= 0) & (ij[:, 1].abs() <= 0)  # the cavity: the middle column above the floor layer
    cup = block[~(middle & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3)]  # walls 4 layers, floor 1
    assert depth(cup) == pytest.approx(3 * spacing, abs=1e-5)
    turned = cup @ torch.tensor([[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]]) + torch.tensor([0.3, -0.2, 0.0])
    assert depth(turned) == pytest.approx(3 * spacing, abs=1e-5)  # anywhere, at any yaw
    big = torch.as_tensor(clay.clay_block((0.036, 0.036, 0.024), spacing), dtype=torch.float32)  # a 3 x 3 cavity, 7 x 7
    bij = torch.round(big / spacing)
    wide = (bij[:, 0].abs() <= 1) & (bij[:, 1].abs() <= 1)
    assert depth(big[~(wide & (bij[:, 2] >= 1)) & (bij[:, 2] <= 2)]) == pytest.approx(2 * spacing, abs=1e-5)
    ball = torch.as_tensor(clay.clay_ball(0.03, spacing), dtype=torch.float32)
    assert depth(ball) <= 0  # the untouched ball: its flat top (3 x 3 particles) is its highest point
    open_side = ~(middle & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3) & ~((ij[:, 0] < 0) & (ij[:, 2] >= 1))
    assert depth(block[open_side]) < 0.005  # a "C": the walls taken away on one side (-x) down to the floor
    # a dent open on a side: a channel three particles wide dug from the middle out through the -x wall
    channel = (ij[:, 1].abs() <= 1) & (ij[:, 0] <= 0) & (ij[:, 2] >= 1)
    assert depth(block[~channel & (ij[:, 2] <= 3)]) < 0.005
    turned_channel = block[~channel & (ij[:, 2] <= 3)] @ torch.tensor([[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    assert depth(turned_channel) < 0.005  # open towards any side
    # the resolution: a slit one particle wide (1.2 cm) has particles beside it in every 60 degree sector
    slit = (ij[:, 1] == 0) & (ij[:, 0] <= 0) & (ij[:, 2] >= 1)
    assert depth(block[~slit & (ij[:, 2] <= 3)]) == pytest.approx(3 * spacing, abs=1e-5)
    disk = torch.as_tensor(clay.clay_block((0.048, 0.048, 0.0), spacing), dtype=torch.float32)  # flattened: one layer
    assert abs(depth(disk)) < 1e-5
    ring = block[~(middle) & (ij[:, 2] <= 3)]  # walls without a floor under the cavity: nothing to try there
    assert depth(ring) <= 0.005
    assert depth(cup) >= 0.02 > depth(block[open_side])  # the rule's 2 cm tells the cup from the C


def _cup_depth_every_centre(points, radius, floor_within, wall_within, arc, directions=24):
    """`clay.cup_depth` the direct way, every centre in every direction in one [B, centre, particle, direction]
    tensor (the library's computation until it skipped the centres that cannot be the deepest): the reference."""
    xy, top = points[..., :2], points[..., 2] + radius
    offset = xy[:, None, :, :] - xy[:, :, None, :]
    dist = torch.linalg.norm(offset, dim=-1)
    floor = torch.where(dist <= floor_within, top[:, None, :], torch.zeros_like(dist)).amax(dim=-1)
    angle = torch.atan2(offset[..., 1], offset[..., 0])
    heading = torch.arange(directions, device=points.device) * (2 * np.pi / directions)
    off_heading = torch.remainder(angle[..., None] - heading + np.pi, 2 * np.pi) - np.pi
    in_sector = (off_heading.abs() <= arc / 2) & ((dist > floor_within) & (dist <= wall_within))[..., None]
    walls = torch.where(in_sector, top[:, None, :, None], torch.zeros_like(off_heading)).amax(dim=2)
    return (walls.amin(dim=-1) - floor).amax(dim=1)


def test_cup_depth_of_clay_equals_every_centre_tried():
    """`clay.cup_depth` tries all directions only round the centres that can be the deepest: its value is bit for bit
    that of every centre tried in every direction (`_cup_depth_every_centre`), on constructed clay (cups, a "C", a
    channel, the ball, a disk, a ring: moved, turned, jittered, several envs in one batch) and on the recorded states
    of the one task that uses it, every second step of PinchClayCupHands' committed samples (the untouched ball to
    the finished cup)."""
    import glob
    import h5py

    spacing, r = 0.012, 0.0058
    rule = (r, 0.007, 0.04, np.radians(60))
    block = torch.as_tensor(clay.clay_block((0.024, 0.024, 0.024), spacing), dtype=torch.float32)
    ij = torch.round(block / spacing)
    middle = (ij[:, 0] == 0) & (ij[:, 1] == 0)
    shapes = [
        block[~(middle & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3)],  # the cup
        block[~(middle & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3) & ~((ij[:, 0] < 0) & (ij[:, 2] >= 1))],  # a "C"
        block[~((ij[:, 1].abs() <= 1) & (ij[:, 0] <= 0) & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3)],  # a channel
        block[~((ij[:, 1] == 0) & (ij[:, 0] <= 0) & (ij[:, 2] >= 1)) & (ij[:, 2] <= 3)],  # a slit
        block[~middle & (ij[:, 2] <= 3)],  # a ring
        torch.as_tensor(clay.clay_ball(0.042, spacing), dtype=torch.float32),
        torch.as_tensor(clay.clay_block((0.048, 0.048, 0.0), spacing), dtype=torch.float32),
    ]
    gen = torch.Generator().manual_seed(0)
    turn = torch.tensor([[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    checked = 0
    for shape in shapes:
        variants = [shape, shape @ turn + torch.tensor([0.3, -0.2, 0.0])]
        variants += [shape + 0.003 * torch.randn(shape.shape, generator=gen) for _ in range(3)]  # kneaded a little
        batch = torch.stack(variants)
        assert torch.equal(clay.cup_depth(batch, *rule), _cup_depth_every_centre(batch, *rule))
        for one in variants:
            assert torch.equal(clay.cup_depth(one[None], *rule), _cup_depth_every_centre(one[None], *rule))
        checked += len(variants)
    samples = sorted(glob.glob(str(Path(__file__).parent.parent / "demos" / "PinchClayCupHands" / "*.h5")))
    assert samples, "PinchClayCupHands' committed samples"
    depths = []
    for sample in samples:
        with h5py.File(sample, "r") as f:
            for episode in f:
                actors = f[episode]["env_states"]["actors"]
                n = sum(name.startswith("clay_") for name in actors)
                points = torch.as_tensor(np.stack([actors[f"clay_{i}"][::2, :3] for i in range(n)], axis=1))
                for chunk in points.split(16):
                    new, reference = clay.cup_depth(chunk, *rule), _cup_depth_every_centre(chunk, *rule)
                    assert torch.equal(new, reference)
                    depths.append(new)
                checked += len(points)
    depths = torch.cat(depths)
    assert depths.max() >= 0.02 and depths.min() < 0  # the states span the ball (no cup) to the cup
    assert checked > 150


def test_mould_fill_on_constructed_clay():
    """A square mould's occupancy (`clay.mould_fill`): clay placed filling its floor by construction fills every
    column; a lump in the middle fills only the middle ones; clay on the rim, outside the walls or stacked above
    the rim fills nothing; the mould's pose (centre, yaw) is honoured."""
    spacing, r, half, depth, cells = 0.012, 0.0058, 0.027, 0.012, 4
    centre, yaw = torch.tensor([[-0.1, 0.03], [0.05, -0.02]]), torch.tensor([0.4, -0.7])

    def placed(local: torch.Tensor) -> torch.Tensor:  # mould-frame points [N, 3] -> world, both envs [2, N, 3]
        c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
        x, y = local[:, 0], local[:, 1]
        world = torch.stack([c * x - s * y + centre[:, :1], s * x + c * y + centre[:, 1:], local[:, 2].expand(2, -1)], -1)
        return world

    ticks = (torch.arange(cells) + 0.5) * (2 * half / cells) - half
    floor = torch.stack([*torch.meshgrid(ticks, ticks, indexing="ij"), torch.full((cells, cells), r)], -1).reshape(-1, 3)
    assert (clay.mould_fill(placed(floor), centre, yaw, half, depth, cells) == 1).all()
    assert clay.mould_cells_filled(placed(floor), centre, yaw, half, depth, cells).all()
    side = torch.tensor([-spacing / 2, spacing / 2])  # a 2 x 2 x 3 lump in the middle: the 4 middle columns
    lump = torch.stack(torch.meshgrid(side, side, r + spacing * torch.arange(3.0), indexing="ij"), -1).reshape(-1, 3)
    assert torch.allclose(clay.mould_fill(placed(lump), centre, yaw, half, depth, cells), torch.tensor(4 / 16))
    wall_top = torch.tensor([[half + 0.005, 0.0, depth + r]])  # on the rim
    outside = torch.tensor([[half + 0.02, 0.0, r], [0.0, -half - 0.02, r]])  # beside the walls on the table
    stacked = floor + torch.tensor([0.0, 0.0, 2 * r])  # a second layer above the rim, nothing below it
    for points in (wall_top, outside, stacked):
        assert (clay.mould_fill(placed(points), centre, yaw, half, depth, cells) == 0).all()
    corner = torch.tensor([[half - r, half - r, r]])  # a particle pressed into one corner: that column only
    filled = clay.mould_cells_filled(placed(corner), centre, yaw, half, depth, cells)
    assert filled[:, cells - 1, cells - 1].all() and filled.sum() == 2
    turned = clay.mould_fill(placed(floor), centre, yaw + np.pi / 4, half, depth, cells)  # the wrong yaw misses columns
    assert (turned < 1).all()


def test_l_occupancy_iou_on_constructed_clay():
    """The L's occupancy IoU (`clay.occupancy_iou` on `clay.cells_occupied`'s grid, target `clay.l_footprint`):
    clay on exactly the L's columns scores 1, the full square three quarters, a heap in one corner low; clay held
    up in the air or pushed past the grid counts for nothing; the grid's pose (centre, yaw) is honoured."""
    spacing, r, cells, margin, top = 0.012, 0.0058, 14, 3, 0.05
    half = cells * spacing / 2
    centre, yaw = torch.tensor([[-0.05, 0.02], [0.03, -0.04]]), torch.tensor([0.3, 2.5])
    target = clay.l_footprint(cells, margin)
    assert target.sum() == 48 and not target[cells // 2:, cells // 2:].any()

    def placed(local: torch.Tensor) -> torch.Tensor:  # grid-frame points [N, 3] -> world, both envs [2, N, 3]
        c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
        x, y = local[:, 0], local[:, 1]
        return torch.stack([c * x - s * y + centre[:, :1], s * x + c * y + centre[:, 1:], local[:, 2].expand(2, -1)], -1)

    ticks = (torch.arange(margin, cells - margin) + 0.5) * spacing - half  # the middle of the square's columns
    square = torch.stack([*torch.meshgrid(ticks, ticks, indexing="ij"), torch.full((8, 8), r)], -1).reshape(-1, 3)
    two_layers = torch.cat([square, square + torch.tensor([0.0, 0.0, spacing])])
    on_l = two_layers[~((two_layers[:, 0] > 0) & (two_layers[:, 1] > 0))]

    def iou(local: torch.Tensor, turn: float = 0.0) -> torch.Tensor:
        return clay.occupancy_iou(placed(local), centre, yaw + turn, half, top, target)

    assert torch.allclose(iou(on_l), torch.ones(2))
    assert torch.allclose(iou(two_layers), torch.full((2,), 0.75))
    corner = torch.stack(torch.meshgrid(ticks[:2], ticks[:2], r + spacing * torch.arange(8.0), indexing="ij"), -1)
    assert (iou(corner.reshape(-1, 3)) <= 4 / 48 + 1e-6).all()  # the same clay heaped on 4 columns
    lifted = torch.cat([on_l, square[(square[:, 0] > 0) & (square[:, 1] > 0)] + torch.tensor([0.0, 0.0, 0.1])])
    assert torch.allclose(iou(lifted), torch.ones(2))  # the quarter's clay held up in the air
    pushed = torch.cat([on_l, torch.tensor([[half + 0.01, 0.02, r], [0.03, half + 0.02, r]])])
    assert torch.allclose(iou(pushed), torch.ones(2))  # past the grid's edge
    beside = torch.cat([on_l, torch.tensor([[-half + spacing / 2, 0.0, r]])])  # one column left of the L
    assert torch.allclose(iou(beside), torch.full((2,), 48 / 49))
    assert (iou(on_l, np.pi / 2) < 0.75).all()  # the L turned a quarter turn: another quarter missing


def test_clay_keeps_the_shape_it_is_pressed_into():
    env = _make("clay", control_mode="pd_joint_delta_pos")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        still = torch.zeros(env.action_space.shape)
        for _ in range(20):
            env.step(still)
        start = base.evaluate()
        for body in base.weight._bodies:
            body.set_mass(2.0)  # a 2 kg press
        base.weight.set_pose(Pose.create_from_pq(torch.tensor([[*base.clay_xy, 0.08]])))
        for _ in range(40):
            env.step(still)
        pressed = base.evaluate()
        state, flat = base.get_state_dict(), base.get_state()
        base.weight.set_pose(Pose.create_from_pq(torch.tensor([[0.05, 0.15, 0.02]])))
        for _ in range(60):
            env.step(still)
        released = base.evaluate()
        assert pressed["height"][0] < 0.7 * start["height"][0]
        assert released["height"][0] < pressed["height"][0] + 0.005  # no spring back
        assert released["footprint_area"][0] > 1.2 * start["footprint_area"][0]
        # the plastic state is part of the env state: restoring it restores the pressed rest shape
        base.set_state_dict(state)
        assert torch.allclose(base.clay.state(), state["clay_rest"])
        # and so does the flat state vector (ManiSkill's set_state alone would leave the rest offsets)
        base.clay.set_state(base.clay.initial_rest.flatten()[None], torch.arange(1))
        base.set_state(flat)
        assert torch.allclose(base.clay.state(), state["clay_rest"])
    finally:
        env.close()


def test_clay_reset_turns_and_scales_its_rest_shape():
    env = _make("clay", control_mode="pd_joint_delta_pos")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        body, idx = base.clay, torch.arange(1)
        origin = torch.tensor([[0.05, -0.05, body.config.radius]])
        body.reset(idx, origin, yaw=torch.tensor([np.pi / 6]), scale=torch.tensor([1.1]))
        start = base.get_state_dict()["clay_start"].reshape(1, -1, 3)
        layout = torch.as_tensor(body.layout, dtype=torch.float32)
        assert torch.allclose(start, body.positions())
        assert clay.height(start, 0)[0] == pytest.approx(1.1 * float(layout[:, 2].max()), abs=1e-6)
        turned = layout[:, :2] @ torch.tensor([[np.cos(np.pi / 6), np.sin(np.pi / 6)], [-np.sin(np.pi / 6), np.cos(np.pi / 6)]], dtype=torch.float32)
        assert torch.allclose(start[0, :, :2] - origin[:, :2], 1.1 * turned, atol=1e-6)
        rest = body.state()
        still = torch.zeros(env.action_space.shape)
        for _ in range(20):
            env.step(still)
        # the rest offsets were turned and scaled with it: the ball only sags a little under its weight
        # (unturned offsets would strain links by 6 mm)
        assert (body.state() - rest).abs().max() < 5e-4
        assert (body.positions() - start).norm(dim=-1).max() < 0.003
    finally:
        env.close()


# ---- liquid / granular and containers -------------------------------------------------------------
@pytest.mark.parametrize("make_shape", [containers.cup, containers.bowl, containers.glass, containers.pitcher])
def test_full_container_is_full(make_shape):
    shape = make_shape()
    pose = Pose.create_from_pq(torch.tensor([[0.1, -0.2, 0.0]]))
    full = particles.pack_in_container(shape, 40, 0.005)[None] + pose.p[:, None]
    assert particles.fraction_inside(full, pose, shape)[0] == 1
    assert particles.fraction_spilled(full, [(pose, shape)])[0] == 0
    outside = full + torch.tensor([0.3, 0, 0])
    assert particles.fraction_inside(outside, pose, shape)[0] == 0
    half = torch.cat([full[:, :20], outside[:, 20:]], dim=1)
    assert particles.fraction_spilled(half, [(pose, shape)])[0] == pytest.approx(0.5)


def test_particles_packed_in_a_narrow_bottle_are_inside_it():
    bottle = containers.bottle(radius=0.03, body_height=0.09, shoulder_height=0.02, neck_radius=0.022,
                               neck_height=0.025, wall=0.003)
    pose = Pose.create_from_pq(torch.tensor([[-0.07, 0.01, 0.0]]))
    packed = particles.pack_in_container(bottle, 80, 0.004)[None] + pose.p[:, None]
    assert particles.fraction_inside(packed, pose, bottle)[0] == 1
    # above the mouth, beside the neck (inside the body's radius, above the shoulder), under the floor
    out = torch.tensor([[[-0.07, 0.01, bottle.height + 0.005], [-0.07 + 0.02, 0.01, 0.125], [-0.07, 0.01, 0.003]]])
    assert particles.fraction_inside(out, pose, bottle)[0] == 0


def test_funnel_passage_counts_particles_through_the_neck_only():
    funnel = containers.funnel()
    neck_top = containers.funnel_neck_top(funnel)
    # a funnel tilted 20 degrees about x, its outlet at (0.1, 0.2, 0.15)
    a = np.radians(20)
    pose = Pose.create_from_pq(torch.tensor([[0.1, 0.2, 0.15]]), torch.tensor([[np.cos(a / 2), np.sin(a / 2), 0, 0]]))

    def world(local):
        local = torch.tensor(local, dtype=torch.float32)[None]
        return pose.p[:, None] + quaternion_apply(pose.q[:, None].expand(-1, local.shape[1], -1), local)

    # particle 0 falls down the cone, through the neck and out; 1 crosses the outlet within one step (in the cone,
    # then below the outlet); 2 leaves over the rim and falls outside; 3 sits in the cone; 4 never enters
    path = [[[0.0, 0.01, neck_top + 0.02], [0.0, 0.0, neck_top + 0.03], [0.03, 0.0, funnel.height - 0.005],
             [0.0, 0.01, neck_top + 0.01], [0.2, 0.0, 0.0]],
            [[0.0, 0.0, neck_top / 2], [0.0, 0.0, -0.04], [funnel.rim_radius + 0.01, 0.0, funnel.height],
             [0.0, 0.01, neck_top + 0.01], [0.2, 0.0, -0.05]],
            [[0.0, 0.0, -0.05], [0.0, 0.0, -0.08], [funnel.rim_radius + 0.015, 0.0, funnel.height - 0.03],
             [0.0, 0.01, neck_top + 0.01], [0.2, 0.0, -0.1]]]
    was_in = torch.zeros(1, 5, dtype=torch.bool)
    through = torch.zeros(1, 5, dtype=torch.bool)
    for step in path:
        was_in, now = particles.funnel_passage(world(step), pose, funnel, was_in)
        through |= now
    assert through.tolist() == [[True, True, False, False, False]]
    assert was_in.tolist() == [[False, False, False, True, False]]
    # the same particles against an upright funnel elsewhere: none passed
    away = Pose.create_from_pq(torch.tensor([[0.5, -0.3, 0.0]]))
    was_in = torch.zeros(1, 5, dtype=torch.bool)
    for step in path:
        was_in, now = particles.funnel_passage(world(step), away, funnel, was_in)
        assert not now.any()


def test_funnel_and_bottle_shells_are_closed_rings():
    funnel, bottle = containers.funnel(), containers.bottle()
    hulls = containers.shell_hulls(funnel)
    assert len(hulls) == containers.SHELL_SECTIONS * (len(funnel.inner) - 1)  # no floor
    assert len(containers.shell_hulls(bottle)) == containers.SHELL_SECTIONS * len(bottle.inner)  # walls + floor
    # the wall pieces reach from the inner radius to the inner radius + wall, all the way round
    radii = np.concatenate([np.linalg.norm(h[:, :2], axis=1) for h in hulls])
    assert radii.min() == pytest.approx(funnel.inner[0][1]) and radii.max() == pytest.approx(funnel.rim_radius + funnel.wall)
    angles = np.unique(np.round(np.concatenate([np.arctan2(h[:, 1], h[:, 0]) for h in hulls]), 6))
    assert len(angles) == containers.SHELL_SECTIONS


def test_base_inside_a_bowl():
    from maniladder_ms.tasks.particles.pour_particles.base import base_inside

    bowl = containers.bowl()
    pose = Pose.create_from_pq(torch.tensor([[0.1, -0.2, 0.0]] * 4))
    # a glass standing on the bowl's floor, on the table beside the bowl, held above the rim, on the rim's edge
    bases = torch.tensor([[0.12, -0.19, 0.01], [0.1, 0.0, 0.0], [0.1, -0.2, bowl.height + 0.02],
                          [0.1 + bowl.rim_radius + 0.01, -0.2, 0.02]])
    assert base_inside(bases, pose, bowl).tolist() == [True, False, False, False]


def test_beans_resting_in_a_tipped_spoon_head_are_inside_its_box():
    from maniladder_ms.objects.tools import SpoonShape

    spoon = SpoonShape()
    centre, half = spoon.bowl_box(0.01)
    # two spoons: one level at the origin, one turned 90 degrees about z and tipped 30 degrees about its
    # own y (front down), 0.2 m away; beans laid on each plate (one bean radius up) in the head's frame
    tilt = np.radians(30)
    qz = [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]
    qy = [np.cos(tilt / 2), 0, np.sin(tilt / 2), 0]
    q = torch.tensor([[1.0, 0, 0, 0], [qz[0] * qy[0], -qz[3] * qy[2], qz[0] * qy[2], qz[3] * qy[0]]])
    pose = Pose.create_from_pq(torch.tensor([[0.0, 0.0, 0.0], [0.2, 0.1, 0.3]]), q)
    r = 0.004
    on_plate = torch.tensor([[0.02, 0.018, spoon.plate + r], [-0.02, -0.018, spoon.plate + r],
                             [0.0, 0.0, spoon.plate + 3 * r]])
    beside = torch.tensor([[0.0, spoon.head_half[1] + 0.01, spoon.plate + r],  # outside the side rim
                           [spoon.front_x + r, 0.0, r],  # just past the front lip
                           [0.0, 0.0, -r]])  # under the plate
    local = torch.cat([on_plate, beside])[None].expand(2, -1, -1)
    world = pose.p[:, None] + quaternion_apply(pose.q[:, None].expand(-1, 6, -1), local)
    assert particles.inside_box(world, pose, centre, half).tolist() == [[True] * 3 + [False] * 3] * 2
    # the same beans counted against the other spoon's pose: none inside
    swapped = Pose.create_from_pq(pose.p.flip(0), pose.q.flip(0))
    assert not particles.inside_box(world, swapped, centre, half).any()


def test_container_decomposition_is_cached(monkeypatch):
    import coacd

    shape = containers.cup()
    visual, parts = containers.cached_parts(shape)
    monkeypatch.setattr(coacd, "run_coacd", lambda *a, **k: pytest.fail("recomputed a cached decomposition"))
    assert containers.cached_parts(shape) == (visual, parts)
    assert len(parts) > 4 and visual.exists()


def test_drape_over_rod_leaves_every_drive_at_rest_and_hangs_as_built():
    """`cloth.drape_over_rod`: every link's two drive frames meet; no particle sinks into the rod; the
    symmetric drape (row 4.5 on top) hangs 40% / 40% (rows 0-3 and 6-9 below the rod's top), the one
    with row 2.6 on top 20% / 60% (rows 2-3 over the top)."""
    rows, cols, rod, r = 10, 8, 0.01, 0.010
    layout = cloth.towel(rows, cols)
    for top_row, split in ((4.5, [0.4, 0.4]), (2.6, [0.2, 0.6])):
        positions, quats = cloth.drape_over_rod(layout, rows, cols, top_row, rod + r + 0.001)
        assert_drives_at_rest(layout, positions, quats)
        assert np.hypot(positions[:, 0], positions[:, 2]).min() > rod + r - 5e-4
        points = torch.tensor(positions, dtype=torch.float32)[None]
        sides = cloth.hanging_fractions(points, torch.zeros(1, 3), torch.tensor([0.0, 1.0, 0.0]), rod)
        assert sides[0].tolist() == pytest.approx(split)


@pytest.mark.parametrize("top_row", [4.5, 2.6])
def test_towel_draped_over_the_bar_stays_put(top_row):
    """Friction on HangTowelOnBar's rod holds a towel wrapped over it at rest, balanced or 1 : 3 (as a real
    towel's would: the capstan ratio e^(mu pi) is ~23 at mu 1): over 200 steps with the arms still the split
    stays and the sheet drifts < 5 mm across the rod (the particles do not roll over it). The proxy's limit
    is near: with row 2.3 on top (the near side's two rows hanging, one of them still on the rod's flank)
    the sheet slides 13 mm and its long side comes down onto the table."""
    from mani_skill.utils.structs.pose import Pose

    from maniladder_ms.tasks.cloth.hang_towel.base import COLS, ROWS
    from maniladder_ms.tasks.cloth.hang_towel.hang_towel_on_bar import HangTowelOnBarEnv

    env = HangTowelOnBarEnv(task_id="HangTowelOnBar", obs_mode="state", control_mode="pd_ee_delta_pose", num_envs=1)
    try:
        env.reset(seed=100)
        wrap = env.bar_radius + env.cloth_config.radius + 0.001
        positions, quats = cloth.drape_over_rod(env.towel.layout, ROWS, COLS, top_row, wrap)
        axis = env.bar.pose.p.clone()
        axis[:, 2] = env.bar_height - env.bar_radius
        env.towel.set_shape(torch.tensor(positions, dtype=torch.float32), torch.tensor(quats, dtype=torch.float32),
                            Pose.create_from_pq(axis))
        start_sides, start_x = env.hanging()[0], env.towel.positions()[0, :, 0].mean()
        hold = torch.zeros(env.action_space.shape)
        for _ in range(200):
            env.step(hold)
        assert torch.allclose(env.hanging()[0], start_sides, atol=0.02)
        assert abs(float(env.towel.positions()[0, :, 0].mean() - start_x)) < 0.005
        assert start_sides.tolist() == pytest.approx([0.4, 0.4] if top_row == 4.5 else [0.2, 0.6])
    finally:
        env.close()


def test_coil_turns_of_polylines_round_a_spool():
    """`spool.coil_turns` on constructed polylines about an axis at (0.1, -0.2), flanges 6 cm in radius between
    heights 3 and 6 cm: a helix of 2.5 turns at 2.5 cm from the axis, rising from 4 to 5 cm, counts 2.5 (wound
    either way); the same helix whose last 1.5 turns drop below the bottom flange counts its first turn only; one
    outside the flanges' rim counts nothing; a coil that leaves the spool and comes back counts up to where it
    left; batched."""
    axis = torch.tensor([0.1, -0.2])
    angle = np.linspace(0, 2.5 * 2 * np.pi, 101)
    z = np.linspace(0.04, 0.05, 101)

    def helix(radius, heights, sense=1.0):
        return np.stack([0.1 + radius * np.cos(sense * angle), -0.2 + radius * np.sin(sense * angle), heights], 1)

    dropped = z.copy()
    dropped[41:] = 0.02  # below the bottom flange after the first turn (points 0-40: one turn)
    away = helix(0.025, z)
    away[60:70, :2] = away[60:70, :2] * 0 + np.array([0.3, 0.3])  # off the spool from point 60 on
    points = torch.as_tensor(np.stack([helix(0.025, z), helix(0.025, z, -1.0), helix(0.025, dropped),
                                       helix(0.08, z), away]), dtype=torch.float32)
    turns = spool.coil_turns(points, axis.expand(5, 2), 0.06, 0.03, 0.06)
    assert turns[0] == pytest.approx(2.5, abs=1e-3)
    assert turns[1] == pytest.approx(2.5, abs=1e-3)
    assert turns[2] == pytest.approx(1.0, abs=1e-3)
    assert turns[3] == 0
    assert turns[4] == pytest.approx(59 / 40, abs=1e-3)  # 59 steps of a fortieth of a turn


def test_rope_coiled_on_the_spool_by_construction():
    """CoilRopeOnSpool's spool and rope: as laid at reset the rope is not coiled (under half a turn: its level run
    from the tie over the flange); its capsules bent in the drum's plane by the angle that makes a polygon round the drum (the
    tied capsule's axis tangent at the tie radius) over the first joints, 2 turns' worth, and straight after:
    `Spool.turns` counts those turns plus the straight part's run off the drum over the flange (the same run as at
    reset), also with the spool turned round on its axle."""
    env = maniladder_ms.make("CoilRopeOnSpool", obs_mode="state", render_backend="cpu")
    try:
        env.reset(seed=0)
        task = env.unwrapped
        sp = task.spool
        level_run = float(sp.turns()[0])  # the rope's straight run from the tie tangent to the drum, over the flange
        assert level_run < 0.5
        cfg = sp.rope.config
        bend = 2 * np.arctan(cfg.segment_length / 2 / sp.tie_radius)  # a capsule edge of a polygon round the drum
        wound = int(round(2 * 2 * np.pi / bend))  # joints bent: two turns
        names = [j.name for j in sp.articulation.active_joints]
        for spin in (0.0, 2.0):
            qpos = torch.zeros(1, len(names))
            qpos[0, names.index("spool_spin")] = spin
            for i in range(1, wound + 1):
                qpos[0, names.index(f"bend_z_{i}")] = bend
            sp.articulation.set_qpos(qpos)
            turns = float(sp.turns()[0])
            # the coil's turns, then the same straight tangent run off the drum as at reset
            assert turns == pytest.approx(wound * bend / (2 * np.pi) + level_run, abs=0.02)
            assert 2.0 < turns < 2.5
    finally:
        env.close()


def test_cord_links_bend_with_the_cord_drive_and_sheet_links_with_the_sheet_drive():
    """`ClothConfig.cord_bend_stiffness` / `cord_bend_damping` set the angular drives of the links with a cord
    particle (HangTowelOnHookHands' stiff corner loop) and leave every sheet link's at `bend_stiffness`; a config
    without them (0) bends cord links like the sheet (every other cloth task)."""
    env = gym.make("ManiLadder-HangTowelOnHookHands-v1", obs_mode="state")
    towel = env.unwrapped.towel
    config, layout = towel.config, towel.layout
    assert config.cord_bend_stiffness > 10 * config.bend_stiffness
    kinds = set()
    for (i, j), drive in zip(layout.links, towel.drives):
        stiffness, damping = drive._objs[0].get_drive_property_slerp()[:2]
        cord = i in layout.cords or j in layout.cords
        kinds.add(cord)
        expected = (config.cord_bend_stiffness, config.cord_bend_damping) if cord else (
            config.bend_stiffness, config.bend_damping)
        assert (stiffness, damping) == pytest.approx(expected, rel=1e-5), (i, j)
    assert kinds == {True, False}
    env.close()
    assert cloth.ClothConfig().cord_bend_stiffness == 0.0  # the default: cords bend like the sheet


# ---- bag --------------------------------------------------------------------------------------------
def test_bag_pouch_and_inside():
    from maniladder_ms.deformables import bag

    spacing, radius, half = 0.025, 0.008, 0.015  # a 3 cm cube in a 6 x 8 bag of 8 mm particles
    layout = bag.pouch(6, 8, spacing, radius)
    assert len(layout.positions) == 2 * 48 and not layout.cords
    seams = [(i, j) for i, j in layout.links if j == i + 48]
    assert len(seams) == 6 + 6 + 6  # both side columns and the bottom row between them; the mouth row is open
    rim = set(layout.named["back_rim"]) | set(layout.named["front_rim"])
    assert not [(i, j) for i, j in seams if i in rim and i not in (layout.named["back_rim"][0], layout.named["back_rim"][-1])]
    rest = torch.as_tensor(layout.positions, dtype=torch.float32) + torch.tensor([0.0, 0.0, radius])
    front = torch.tensor(layout.named["front"])
    mouth_x, bottom_x = float(rest[layout.named["back_rim"][0], 0]), float(rest[layout.named["back_bottom"][0], 0])
    kw = dict(spacing=spacing, min_depth=0.03, max_height=0.045)
    # the bag closed, the front panel lifted over a cube by construction (a tent 5 cm up), the mouth held open
    # (its two last rows of the front panel 10 cm up), and as it lies flat
    tent = rest.clone()
    tent[front, 2] += 0.05
    opened = rest.clone()
    opened[torch.tensor(layout.named["front"][-16:]), 2] += 0.1
    cases = [  # (particles, cube centre, inside?)
        (tent, (0.0, 0.0, 2 * radius + half), True),  # on the back panel under the front: inside
        (tent, (bottom_x + 0.01, 0.03, 2 * radius + half), True),
        (opened, (mouth_x - 0.035, 0.0, 2 * radius + half), True),  # under the held-open mouth, past it by 3.5 cm
        (rest, (0.0, 0.0, 4.2 * radius + half), False),  # resting on top of the closed bag
        (tent, (0.0, 0.0, 0.05 + 4.2 * radius + half), False),  # on top of the tent
        (rest, (0.0, 0.13, half), False),  # on the table beside the bag
        (rest, (bottom_x - 0.03, 0.0, half), False),  # beyond its bottom
        (tent, (0.0, 0.0, -0.005), False),  # under the back panel
        (opened, (mouth_x - 0.01, 0.0, 2 * radius + half), False),  # at the lip, less than min_depth in
        (opened, (mouth_x - 0.035, 0.0, 0.07), False),  # held above the open mouth
    ]
    points = torch.stack([c[0] for c in cases])
    cube = torch.tensor([c[1] for c in cases])
    expected = [c[2] for c in cases]
    assert bag.inside(points, layout, cube, **kw).tolist() == expected
    # on top of the front panel is not inside however high the pocket may reach (the front-panel rule decides)
    assert not bag.inside(points[3:5], layout, cube[3:5], spacing, 0.03, 1.0).any()
    # the same bag turned half round (its mouth towards -x, as the task lays it) and moved: the same answers
    turn = torch.tensor([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
    shift = torch.tensor([-0.05, 0.02, 0.0])
    assert bag.inside(points @ turn.T + shift, layout, cube @ turn.T + shift, **kw).tolist() == expected
    frame = bag.bag_frame(points @ turn.T + shift, layout)
    assert frame["u"][0].tolist() == pytest.approx([-1.0, 0.0, 0.0], abs=1e-6)
    assert frame["w"][0].tolist() == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)
    assert frame["half_width"][0] == pytest.approx(3.5 * spacing, abs=1e-6)


def test_clip_row_and_order_of_entry():
    """A row of three clips 10 cm apart along a turned line: the centres lie where constructed, and a cable laid
    through all three slots is inside each (3 capsules of 2 cm in each 6 cm clip), one lying across the slots'
    tops (the walls' top, above it) in none. The order record: clips entered one at a time while pressed, never
    ahead of their turn; a clip seated before the one ahead of it was entered breaks the order."""
    from maniladder_ms.deformables import clip_route

    yaw = torch.tensor([0.4, -2.5])
    middle = torch.tensor([[-0.1, -0.08], [0.02, 0.05]])
    centres = clip_route.row_centres(middle, yaw, 0.1, 3)
    along = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
    assert torch.allclose(centres[:, 1], middle, atol=1e-6)
    assert torch.allclose(centres[:, 0], middle - 0.1 * along, atol=1e-6)
    assert torch.allclose(centres[:, 2], middle + 0.1 * along, atol=1e-6)
    # a straight 20-capsule cable (2 cm capsules) along the row through every slot, low in it; the same cable 1.6 cm
    # higher, its centres above the walls' top (16 mm)
    s = (torch.arange(20) - 10) * 0.02  # capsule 10 at the row's middle, 3 capsule centres within each clip
    xy = middle[:, None] + s[None, :, None] * along[:, None]
    low = torch.cat([xy, torch.full((2, 20, 1), 0.012)], dim=2)
    high = torch.cat([xy, torch.full((2, 20, 1), 0.024)], dim=2)
    for points, expected in ((low, 3.0), (high, 0.0)):
        for i in range(3):
            count = metrics.inside_channel_fraction(points, centres[:, i], yaw, 0.0095, 0.03, 0.016) * 20
            assert count.tolist() == pytest.approx([expected, expected])
    # order: clip 0 pressed -> entered; clip 2 seated while clip 1 is not entered -> broken
    entered = torch.zeros(3, 3, dtype=torch.bool)
    broken = torch.zeros(3, dtype=torch.bool)
    seated = torch.tensor([[True, False, False], [True, True, True], [False, False, False]])
    pressing = torch.tensor([True, True, True])
    entered, broken = clip_route.enter_in_order(entered, broken, seated, pressing)
    assert entered.tolist() == [[True, False, False], [True, False, False], [False, False, False]]
    assert broken.tolist() == [False, True, False]
    # env 0: clip 1 seated but not pressed -> not entered; then pressed -> entered; then clip 2 pressed
    for seat, press in (([True, True, False], False), ([True, True, False], True), ([True, True, True], True)):
        entered, broken = clip_route.enter_in_order(entered, broken, torch.tensor([seat] * 3),
                                                    torch.tensor([press] * 3))
    assert entered[0].tolist() == [True, True, True] and not broken[0]
    # env 2 never had clip 0 entered before the others were seated: broken
    assert broken[2]
