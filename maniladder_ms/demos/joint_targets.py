"""A demo's actions as absolute joint targets (`pd_joint_pos`), whatever mode it was recorded in.

Every arm controller of our agents ends in PD drive targets: `pd_ee_delta_pose` solves IK for them, and
`pd_joint_delta_pos` adds its delta to them. Replaying an episode from its seeded reset (which reproduces its
recorded first state: `demos verify`'s drift 0) in its own mode and reading each arm controller's drive target
after every step gives the `pd_joint_pos` action that sets the very same targets, so the converted episode
replays the same motion. Parts that are identical in both modes (grippers, LEAP hands, the mobile base's velocity)
keep their recorded action slice.

ManiSkill's `replay_trajectory` converts from `pd_joint_pos` to the delta modes, not back; the reference
policy acts in absolute joint targets (see `maniladder_ms.policy.flow`), hence this direction.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from .files import (
    DemoFileError, episode_arrays, episode_reset_kwargs, flat_state, load_demo_json, open_demo_h5, replay_env_kwargs,
    state_at,
)

TARGET_MODE = "pd_joint_pos"
RESET_TOLERANCE = 1e-6  # the seeded reset reproduces a demo's first state exactly (`demos verify`'s drift 0)


def _part_layout(agent, source_mode: str) -> list[tuple[str, int, bool]]:
    """(part name, its action width in `source_mode`, whether it becomes drive targets) per controller part."""
    configs = agent._controller_configs
    if TARGET_MODE not in configs:
        raise ValueError(f"agent {agent.uid} has no {TARGET_MODE} control mode to convert into")
    controller = agent.controller
    layout = []
    for name, part in controller.controllers.items():
        same = configs[TARGET_MODE][name] == configs[source_mode][name]
        if not same and not getattr(part, "sets_target_qpos", False):
            raise ValueError(f"{agent.uid}: controller part {name!r} in {source_mode} sets no joint targets")
        layout.append((name, part.action_space.shape[-1], not same))
    return layout


def joint_target_episodes(h5_path, progress: bool = False) -> Iterator[tuple[np.ndarray, bool, dict]]:
    """Per episode of a demo file: (its actions as `pd_joint_pos` targets (T, A'), whether the replay in the
    recorded mode still succeeded, the episode's json). An episode already in `pd_joint_pos` is passed through."""
    import torch
    from tqdm import tqdm

    import maniladder_ms

    h5_path = Path(h5_path)
    meta = load_demo_json(h5_path)
    env_kwargs = replay_env_kwargs(meta)
    source_mode = env_kwargs.get("control_mode")
    if source_mode is None:
        raise DemoFileError(f"{h5_path}: the json names no control_mode; cannot convert its actions")
    with open_demo_h5(h5_path) as h5:
        if source_mode == TARGET_MODE:
            for ep in meta["episodes"]:
                actions, _ = episode_arrays(h5, ep["episode_id"], str(h5_path))
                yield np.asarray(actions, np.float32), bool(ep.get("success", True)), ep
            return
        env = maniladder_ms.make(meta["task_spec"].id, obs_mode="state", **env_kwargs)
        base = env.unwrapped
        try:
            for ep in tqdm(meta["episodes"], desc=f"joint targets {h5_path.parent.name}", disable=not progress):
                actions, states = episode_arrays(h5, ep["episode_id"], str(h5_path))
                # the seeded reset, as `demos verify` replays: writing the recorded first state back over it moved
                # single-arm LEAP replays off the recorded motion (PlaceMugOnCoasterHand's calibration demos 0 and 2:
                # converted arm targets 0.12 and 0.05 rad off; its demo 1 no longer succeeded)
                env.reset(**episode_reset_kwargs(ep))
                gap = float(np.abs(flat_state(base.get_state_dict()) - flat_state(state_at(states, 0))).max())
                if gap > RESET_TOLERANCE:
                    raise DemoFileError(f"{h5_path}: episode {ep['episode_id']}: the seeded reset is {gap:.3g} away "
                                        "from the recorded first state (the task changed since recording); "
                                        "re-record the demos")
                # a reconfiguring reset rebuilds the agent: read its controller after it
                parts = base.agent.controller.controllers
                layout = _part_layout(base.agent, source_mode)
                out, info = [], {}
                for action in actions:
                    _, _, _, _, info = env.step(torch.as_tensor(action)[None])
                    row, start = [], 0
                    for name, width, to_targets in layout:
                        if to_targets:
                            row.append(parts[name]._target_qpos[0].cpu().numpy())
                        else:
                            row.append(np.asarray(action[start:start + width]))
                        start += width
                    out.append(np.concatenate(row))
                yield np.asarray(out, np.float32), bool(info["success"][0]) if info else False, ep
        finally:
            env.close()
