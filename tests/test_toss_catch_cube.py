"""TossCatchCube (`tasks.rigid.catch_ball`): the CatchBall family's guards. A cube put into the right gripper from
just above (no flight) is no toss, and a cube that touched the table after the pick spoils the episode for good."""

import torch

import maniladder_ms
from maniladder_ms.geometry import face_yaw
from maniladder_ms.solvers import EPISODE_RESET_OPTIONS
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.rigid.catch_ball import toss_catch_cube as solver


def _picked(seed: int):
    """An env whose left gripper has picked the cube (the solver's pick), and its driver."""
    env = maniladder_ms.make("TossCatchCube", obs_mode="state", control_mode="pd_ee_delta_pose")
    env.reset(seed=seed, options=dict(EPISODE_RESET_OPTIONS))
    task = env.unwrapped
    s = DrivenSolver(env)
    yaw = face_yaw(task.cube.pose.q, solver.THROW_YAW)
    s.pick("left_arm", "left_gripper", task.cube.pose.p.clone(), yaw, lift=0.1)
    assert bool(s.info["picked"][0]) and not bool(s.info["touched_table"][0])
    return env, task, s


def test_a_cube_put_into_the_cup_from_above_is_no_toss():
    """The left carries the cube over the right's palm-up cup and lets go just above it, and the right closes: the
    cube's drop is neither long nor far enough for a toss, so there is no toss and no success."""
    env, task, s = _picked(100)
    try:
        n, device = task.num_envs, task.device
        cup = s.tcp("right_arm").p.clone()
        q = top_down_quat(solver.THROW_YAW, n, device)
        above = cup + torch.tensor([0.0, 0.0, task.cube_half + 0.02], device=device)
        s.move({"left_arm": (above + torch.tensor([0.0, 0.0, 0.1], device=device), q)}, max_steps=80, pos_tol=0.01)
        s.move({"left_arm": (above, q)}, max_steps=40, pos_tol=0.005)
        s.release("left_gripper", steps=3)
        s.move({"left_arm": (above + torch.tensor([0.0, 0.0, 0.1], device=device), q)}, max_steps=20)
        s.grasp("right_gripper")
        for _ in range(5):
            s.step()
        info = s.info
        assert bool(info["picked"][0])
        assert not bool(info["tossed"][0]) and not bool(info["caught"][0]) and not bool(info["success"][0])
    finally:
        env.close()


def test_a_cube_dropped_on_the_table_after_the_pick_is_latched():
    """The left lifts the cube and opens over the table: the table contact is latched (checked at every physics
    step) and stays set, whatever follows."""
    env, task, s = _picked(101)
    try:
        s.release("left_gripper", steps=15)
        info = s.info
        assert bool(info["touched_table"][0]) and not bool(info["tossed"][0]) and not bool(info["success"][0])
        # the flight off the gripper was too short and too near to count, and lying on the table is no flight
        assert int(info["airborne_steps"][0]) == 0
        state = env.unwrapped.get_state_dict()
        assert float(state["memory_touched_table"][0, 0]) == 1.0
    finally:
        env.close()
