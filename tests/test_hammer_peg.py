"""HammerPeg (`tasks.rigid.hammer_peg`, `objects.hammer`): the peg's friction and the rule's blows."""

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

import maniladder_ms
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import EPISODE_RESET_OPTIONS
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rigid import hammer_peg as solver


def _make():
    return maniladder_ms.make("HammerPeg", obs_mode="state", control_mode="pd_ee_delta_pose")


def test_the_peg_holds_against_less_than_its_friction_and_a_peg_put_flush_is_not_hammered():
    env = _make()
    try:
        env.reset(seed=0)
        task = env.unwrapped
        peg = task.peg._bodies[0]
        start = float(task.peg_proud()[0])

        def push(force: float, control_steps: int = 4):
            for _ in range(control_steps * task._sim_steps_per_control):
                peg.add_force_torque(np.array([0.0, 0.0, -force]), np.zeros(3))
                task.scene.step()

        push(0.8 * task.hold_force)
        assert abs(float(task.peg_proud()[0]) - start) < 0.0005  # a push under the friction: it stays
        push(1.2 * task.hold_force)
        assert float(task.peg_proud()[0]) < start - 0.01  # over it: it gives way
        # put flush without a blow: flush, but not hammered in
        task.board.set_qpos(torch.full((1, 1), task.board_shape.rise))
        task.board.set_qvel(torch.zeros(1, 1))
        *_, info = env.step(torch.zeros(env.action_space.shape))
        assert bool(info["peg_flush"][0]) and not bool(info["hammered_in"][0]) and not bool(info["success"][0])
    finally:
        env.close()


def test_a_slow_push_with_the_held_hammer_is_no_blow():
    """The solver's grasp and aim, then the face pressed down onto the peg `push_step` a control step (a push,
    not a blow): however far the arm drives the peg, its descent is not hammered and the task is not solved."""
    push_step = 0.002  # m a control step: 0.04 m/s, well under `strike_speed`
    env = _make()
    try:
        env.reset(seed=100, options=dict(EPISODE_RESET_OPTIONS))
        task = env.unwrapped
        s = DrivenSolver(env)
        shape = task.HAMMER
        local = torch.tensor([[shape.head_x - solver.GRASP_FROM_HEAD, 0.0, shape.handle_height / 2 + solver.GRASP_ABOVE]])
        grasp = (task.hammer.pose * Pose.create_from_pq(local)).p
        s.pick("arm", "gripper", grasp, DrivenSolver.neutral_yaw(yaw_of(task.hammer.pose.q), np.pi), lift=solver.LIFT)
        q = s.tcp("arm").q
        start = float(task.peg_proud()[0])
        top = task.peg_top().clone()
        height = solver.RAISE
        for _ in range(200):
            target = top.clone()
            target[:, 2] += height
            s.step({"arm": (target - (task.striking_face() - s.tcp("arm").p), q)})
            height = max(height - push_step, -start)
            assert float(task.memory["head_speed"][0, 0]) < task.strike_speed
        info = s.info
        assert bool(info["hammer_grasped"][0])
        assert float(task.peg_proud()[0]) < start - 0.005  # the arm's push does drive the peg ...
        assert float(info["hammered"][0]) == 0.0  # ... but none of it counts as hammered
        assert not bool(info["success"][0])
    finally:
        env.close()
