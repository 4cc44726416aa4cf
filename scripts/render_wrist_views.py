"""Wrist-camera views of demo episode 0 at fractions of its length (default 0.35, 0.5, 0.65, 0.9; the last also
from the front camera), tiled into one PNG: the LEAP wrist cameras at grasp moments (docs/agents/wrist/).

    PYTHONPATH=. python scripts/render_wrist_views.py demos/LiftBottleHand/<file>.h5 docs/agents/wrist/LiftBottleHand_after.png
"""
import sys
from pathlib import Path
import numpy as np
import maniladder_ms
from maniladder_ms.demos.files import episode_arrays, episode_reset_kwargs, load_demo_json, open_demo_h5, replay_env_kwargs, state_at, torch_state
from maniladder_ms.render import save_tiled
h5_path, out = Path(sys.argv[1]), sys.argv[2]
fracs = [float(f) for f in (sys.argv[3].split(",") if len(sys.argv) > 3 else ["0.35", "0.5", "0.65", "0.9"])]
meta = load_demo_json(h5_path)
env = maniladder_ms.make(meta["task_spec"].id, obs_mode="rgb", sensor_configs=dict(width=256, height=256), **replay_env_kwargs(meta))
base = env.unwrapped
images = {}
with open_demo_h5(h5_path) as h5:
    ep = meta["episodes"][0]
    actions, states = episode_arrays(h5, ep["episode_id"], str(h5_path))
    env.reset(**episode_reset_kwargs(ep))
    for f in fracs:
        t = int(f * len(actions))
        base.set_state_dict(torch_state(state_at(states, t)))
        obs = base.get_obs(unflattened=True)
        for cam in obs["sensor_data"]:
            if cam.endswith("hand_camera") or (f == fracs[-1] and cam == "front_camera"):
                images[f"{cam} t={t}"] = obs["sensor_data"][cam]["rgb"][0].cpu().numpy()
save_tiled(images, f"{meta['task_spec'].id} episode {ep['episode_id']} wrist views", Path(out))
print(out, len(actions))
env.close()
