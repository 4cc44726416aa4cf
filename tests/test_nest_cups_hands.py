"""NestCupsHands (`tasks.rigid.nest_cups_hands`): the nesting rule on constructed poses."""

import numpy as np
import pytest
import torch

from mani_skill.utils.structs.pose import Pose

import maniladder_ms
from maniladder_ms.tasks.rigid.nest_cups_hands import NAMES


@pytest.fixture(scope="module")
def env():
    env = maniladder_ms.make("NestCupsHands", obs_mode="state", control_mode="pd_ee_delta_pose")
    yield env
    env.close()


def _pose(task, name, xyz, tilt_deg=0.0):
    """Put cup `name` at bottom centre `xyz`, tilted `tilt_deg` about world x, at rest."""
    half = np.deg2rad(tilt_deg) / 2
    q = torch.tensor([[np.cos(half), np.sin(half), 0.0, 0.0]], dtype=torch.float32)
    cup = task.cups[name]
    cup.set_pose(Pose.create_from_pq(torch.tensor([xyz], dtype=torch.float32), q))
    cup.set_linear_velocity(torch.zeros(1, 3))
    cup.set_angular_velocity(torch.zeros(1, 3))


def _nest(task, middle=(0.0, 0.0, 0.0), small=(0.0, 0.0, 0.0), middle_tilt=0.0):
    """The three cups nested at (-0.1, 0) (offsets from the seated poses), as the rule reads them (no step)."""
    floor = task.shapes["large"].floor
    base = np.array([-0.1, 0.0, 0.0])
    _pose(task, "large", base.tolist())
    _pose(task, "middle", (base + [0, 0, floor] + middle).tolist(), middle_tilt)
    _pose(task, "small", (base + [0, 0, 2 * floor] + np.array(middle) + small).tolist())
    return task.evaluate()


def test_seated_nest_counts_and_each_way_of_missing_it_does_not(env):
    env.reset(seed=0)
    task = env.unwrapped
    info = _nest(task)
    assert bool(info["success"][0]), info
    assert abs(float(info["middle_rim_gap"][0]) - task.shapes["large"].floor) < 1e-4
    # the small cup off the middle's axis by more than max_axis_offset (resting on its rim)
    assert not bool(_nest(task, small=(task.max_axis_offset * 1.5, 0.0, 0.0))["small_in_middle"][0])
    # wedged high: its rim more than max_rim_gap above the middle's
    assert not bool(_nest(task, small=(0.0, 0.0, task.max_rim_gap + 0.005))["small_in_middle"][0])
    # the middle cup tilted past max_tilt
    assert not bool(_nest(task, middle_tilt=task.max_tilt + 5)["middle_in_large"][0])
    # the middle cup beside the large one, on the table
    info = _nest(task, middle=(0.12, 0.0, -task.shapes["large"].floor))
    assert not bool(info["middle_in_large"][0]) and not bool(info["success"][0])


def test_cups_start_apart_and_in_size_order(env):
    env.reset(seed=3)
    task = env.unwrapped
    info = task.evaluate()
    assert not bool(info["success"][0])
    radii = [task.shapes[n].rim_radius for n in NAMES]
    assert radii == sorted(radii, reverse=True)
    for inner, outer in zip(NAMES[1:], NAMES[:-1]):  # each cup's outer wall fits inside the next one's inner wall
        gap = task.shapes[outer].rim_radius - task.shapes[inner].rim_radius - task.shapes[inner].wall
        assert 0.002 <= gap <= 0.005


def test_cup_collision_is_the_sector_walls_and_one_floor_disc():
    """`cup_hulls`: the walls are `containers.shell_hulls`' sectors, the floor one disc of the volume (and
    height) of `shell_hulls`' floor wedges together."""
    import trimesh

    from maniladder_ms.objects import containers
    from maniladder_ms.tasks.rigid.nest_cups_hands import cup_hulls, cup_shapes

    for shape in cup_shapes().values():
        wedges_and_walls = containers.shell_hulls(shape)
        mine = cup_hulls(shape)
        walls = [p for p in wedges_and_walls if p[:, 2].max() > shape.floor + 1e-9]
        wedges = [p for p in wedges_and_walls if p[:, 2].max() <= shape.floor + 1e-9]
        assert len(walls) == len(wedges) == containers.SHELL_SECTIONS and len(mine) == len(walls) + 1
        for a, b in zip(walls, mine[:-1]):
            np.testing.assert_allclose(a, b)
        disc = trimesh.convex.convex_hull(mine[-1])
        wedge_volume = sum(trimesh.convex.convex_hull(w).volume for w in wedges)
        assert disc.volume == pytest.approx(wedge_volume, rel=1e-9)
        assert disc.bounds[:, 2].tolist() == [0.0, shape.floor]


def test_rule_reads_the_inner_cup_in_the_containers_frame(env):
    """`nested`'s quaternion arithmetic gives the container-frame position `Pose` arithmetic gives."""
    env.reset(seed=1)
    task = env.unwrapped
    _pose(task, "large", [-0.1, 0.02, 0.01], tilt_deg=25.0)
    _pose(task, "middle", [-0.08, 0.05, 0.04], tilt_deg=-40.0)
    a, b = task.cups["middle"].pose, task.cups["large"].pose
    local = (b.inv() * a).p
    got = task.nested("middle", "large")
    assert float(got["axis_offset"][0]) == pytest.approx(float(torch.linalg.norm(local[0, :2])), abs=1e-6)
    assert float(got["rim_gap"][0]) == pytest.approx(float(local[0, 2]), abs=1e-6)  # equal heights
