"""Shared setup for the cupbeans6 pour probes: the CupBeansHands env (registered since session 20; the probes were
written before, so they register it if needed) with a 5000-step limit."""
import gymnasium as gym
import torch

from maniladder_ms.envs import register_task
from maniladder_ms.envs.registration import REGISTERED_ENVS  # noqa: F401
from maniladder_ms.tasks import cup_beans_hands as cbh


def make_env(**kw):
    try:
        register_task("CupBeansHands")(cbh.CupBeansHandsEnv)
    except Exception as e:  # already registered
        print("register:", e)
    kw.setdefault("obs_mode", "state")
    kw.setdefault("control_mode", "pd_ee_delta_pose")
    kw.setdefault("max_episode_steps", 5000)
    return gym.make("ManiLadder-CupBeansHands-v1", **kw)
