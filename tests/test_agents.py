"""The ManiLadder agents: registered, load in an empty ManiLadder scene, every controller steps, rest
keyframe reached, state round trip, wrist cameras, TidyBot base drive, cube lifts with the helpers."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from mani_skill.agents.registration import REGISTERED_AGENTS
from mani_skill.utils.building import actors
from mani_skill.utils.registration import register_env
from mani_skill.utils.structs.pose import Pose

import maniladder_ms  # noqa: F401  (registers the agents)
from maniladder_ms.agents import AGENT_UIDS
from maniladder_ms.agents.helpers import Driver, drive_base_to, hold_action, top_down_quat
from maniladder_ms.envs.base import ManiLadderEnv

MODES = ("pd_joint_pos", "pd_joint_delta_pos", "pd_ee_delta_pose")
ACTION_DIMS = {  # per mode, as documented in the agents' docstrings
    "ml_panda": (8, 8, 7),
    "ml_panda_leap": (23, 23, 22),
    "ml_dual_panda": (16, 16, 14),
    "ml_dual_panda_leap": (46, 46, 44),
    "ml_tidybot": (11, 11, 10),
}
CAMERAS = {
    "ml_panda": {"hand_camera"},
    "ml_panda_leap": {"hand_camera"},
    "ml_dual_panda": {"left_hand_camera", "right_hand_camera"},
    "ml_dual_panda_leap": {"left_hand_camera", "right_hand_camera"},
    "ml_tidybot": {"hand_camera"},
}
CUBE_HALF = 0.025
# where the lift tests put the cube (world xy, jittered +-3 cm), in reach of the (left) arm
CUBE_XY = {"ml_panda": (-0.15, 0.0), "ml_panda_leap": (-0.15, 0.0), "ml_dual_panda": (-0.15, 0.3),
           "ml_dual_panda_leap": (-0.15, 0.3), "ml_tidybot": (-0.45, 0.0)}


@register_env("ManiLadderAgentTest-v1", max_episode_steps=200)
class AgentTestEnv(ManiLadderEnv):
    """An empty ManiLadder scene (optionally one 5 cm cube) for any of the agents."""

    SUPPORTED_ROBOTS = list(AGENT_UIDS)

    def __init__(self, *args, with_cube: bool = False, **kwargs):
        self.with_cube = with_cube
        super().__init__(*args, task_id="PickPlacePen", **kwargs)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        if self.with_cube:
            self.cube = actors.build_cube(self.scene, half_size=CUBE_HALF, color=[0.8, 0.2, 0.2, 1], name="cube",
                                          initial_pose=Pose.create_from_pq([0, 0, CUBE_HALF]))

    def _initialize_episode(self, env_idx, options):
        super()._initialize_episode(env_idx, options)
        if self.with_cube:
            b = len(env_idx)
            xy = torch.tensor(CUBE_XY[self.agent.uid]) + (torch.rand(b, 2) * 2 - 1) * 0.03
            p = torch.cat([xy, torch.full((b, 1), CUBE_HALF)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.pi / 4
            q = torch.stack([torch.cos(yaw / 2), torch.zeros(b), torch.zeros(b), torch.sin(yaw / 2)], dim=1)
            self.cube.set_pose(Pose.create_from_pq(p, q))

    def evaluate(self):
        return {}

    def _get_obs_extra(self, info):
        return {}

    def compute_dense_reward(self, obs, action, info):
        return torch.zeros(self.num_envs, device=self.device)

    def compute_normalized_dense_reward(self, obs, action, info):
        return self.compute_dense_reward(obs, action, info)


def make(uid, mode="pd_joint_pos", **kw):
    kw.setdefault("robot_init_qpos_noise", 0.0)
    return gym.make("ManiLadderAgentTest-v1", robot_uids=uid, control_mode=mode, obs_mode="state", **kw)


def test_registered():
    assert set(AGENT_UIDS) <= set(REGISTERED_AGENTS)


def test_generated_descriptions_up_to_date():
    import importlib.util

    from maniladder_ms.paths import REPO_DIR

    spec = importlib.util.spec_from_file_location("make_agents", REPO_DIR / "scripts" / "make_agents.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--check"]) == 0


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_every_controller_steps(uid):
    for mode, dim in zip(MODES, ACTION_DIMS[uid]):
        env = make(uid, mode)
        try:
            assert env.action_space.shape == (dim,), (mode, env.action_space.shape)
            assert set(env.unwrapped.agent.supported_control_modes) >= set(MODES)
            env.action_space.seed(0)
            obs, _ = env.reset(seed=0)
            for _ in range(5):
                obs, *_ = env.step(env.action_space.sample())
            assert torch.isfinite(obs).all()
            # the action that holds the current joint targets keeps the robot where it is
            q0 = env.unwrapped.agent.robot.get_qpos().clone()
            for _ in range(5):
                env.step(hold_action(env.unwrapped.agent))
            assert torch.isfinite(env.unwrapped.agent.robot.get_qpos()).all()
            assert set(env.unwrapped._sensors) >= CAMERAS[uid]
            del q0
        finally:
            env.close()


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_rest_keyframe_reached_and_held(uid):
    env = make(uid, "pd_joint_pos")
    try:
        env.reset(seed=0)
        agent = env.unwrapped.agent
        rest = torch.as_tensor(agent.keyframes["rest"].qpos, dtype=torch.float32)[None]
        assert torch.allclose(agent.robot.get_qpos(), rest, atol=1e-4)
        # from a perturbed pose, holding the rest targets brings the robot back to rest
        perturbed = rest.clone()
        n = len(agent.arm_joint_names)
        arm_idx = [i for i, j in enumerate(agent.robot.get_active_joints()) if j.name in agent.arm_joint_names]
        assert len(arm_idx) == n
        perturbed[:, arm_idx] += 0.1
        agent.robot.set_qpos(perturbed)
        for _ in range(40):
            env.step(hold_action(agent, rest))
        err = (agent.robot.get_qpos() - rest).abs().max().item()
        assert err < 0.01, err
    finally:
        env.close()


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_state_round_trip(uid):
    env = make(uid, "pd_joint_delta_pos")
    try:
        env.action_space.seed(1)
        env.reset(seed=1)
        for _ in range(5):
            env.step(env.action_space.sample())
        base = env.unwrapped
        state = base.get_state_dict()
        obs = base.get_obs()
        for _ in range(5):
            env.step(env.action_space.sample())
        assert not torch.allclose(base.get_obs(), obs)
        base.set_state_dict(state)
        assert torch.allclose(base.get_obs(), obs, atol=1e-5)
    finally:
        env.close()


def test_tidybot_drives_and_turns():
    env = make("ml_tidybot", "pd_ee_delta_pose")
    try:
        env.reset(seed=0)
        driver = Driver(env)
        agent = env.unwrapped.agent
        start = agent.robot.get_qpos()[:, :3].clone()
        drive_base_to(driver, start + torch.tensor([[-0.5, 0.0, 0.0]]))  # 0.5 m back from the table
        q = agent.robot.get_qpos()[0, :3]
        assert abs(q[0].item() - start[0, 0].item() + 0.5) < 0.02 and abs(q[1].item()) < 0.02
        drive_base_to(driver, torch.tensor([[q[0].item(), 0.0, np.pi / 2]]))  # turn 90 degrees
        q = agent.robot.get_qpos()[0, :3]
        assert abs(np.degrees(q[2].item()) - 90) < 3
        # the base link really moved and turned in the world
        yaw = 2 * np.arctan2(agent.base_link.pose.q[0, 3].item(), agent.base_link.pose.q[0, 0].item())
        assert abs(np.degrees(yaw) - 90) < 3
    finally:
        env.close()


# ---- cube lifts ----------------------------------------------------------------------------------
def lift_cube(env, seed: int, arm: str, ee_part: str, leap: bool) -> bool:
    """Top-down grasp of the cube with one arm's helpers; True if it ends 5 cm above the table."""
    env.reset(seed=seed)
    base = env.unwrapped
    driver = Driver(env)
    cube = base.cube
    n = base.num_envs
    p = cube.pose.p.clone()
    # cube yaw (mod 90 degrees) so the fingers close on two faces
    w, z = cube.pose.q[:, 0], cube.pose.q[:, 3]
    yaw = torch.remainder(2 * torch.atan2(z, w) + np.pi / 4, np.pi / 2) - np.pi / 4
    q = top_down_quat(yaw, n)
    above = p + torch.tensor([0, 0, 0.1])
    if leap:
        driver.set_ee(ee_part, "open", steps=1)
        grasp = p + torch.tensor([0, 0, 0.0])
    else:
        driver.grip(False, ee_part, steps=1)
        grasp = p + torch.tensor([0, 0, 0.0])
    driver.move({arm: (above, q)}, max_steps=60)
    driver.move({arm: (grasp, q)}, max_steps=40, pos_tol=0.003)
    if leap:
        driver.set_ee(ee_part, "power", steps=15)
    else:
        driver.grip(True, ee_part, steps=10)
    driver.move({arm: (p + torch.tensor([0, 0, 0.15]), q)}, max_steps=40)
    for _ in range(5):
        driver.step()
    return bool((cube.pose.p[:, 2] > CUBE_HALF + 0.05).all())


LIFTS = [("ml_panda", "arm", "gripper", False), ("ml_tidybot", "arm", "gripper", False),
         ("ml_dual_panda", "left_arm", "left_gripper", False)]


@pytest.mark.parametrize("uid,arm,ee,leap", LIFTS)
def test_gripper_agents_lift_cube(uid, arm, ee, leap):
    env = make(uid, "pd_ee_delta_pose", with_cube=True)
    try:
        results = [lift_cube(env, seed, arm, ee, leap) for seed in range(3)]
        assert sum(results) >= 3, results
    finally:
        env.close()
