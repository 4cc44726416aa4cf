"""Shared setup for the CupBeansHands probes: its env with a 5000-step limit (a probe runs past the horizon)."""
import maniladder_ms


def make_env(**kw):
    kw.setdefault("obs_mode", "state")
    kw.setdefault("control_mode", "pd_ee_delta_pose")
    kw.setdefault("max_episode_steps", 5000)
    return maniladder_ms.make("CupBeansHands", **kw)
