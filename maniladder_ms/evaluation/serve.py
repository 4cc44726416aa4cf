"""`maniladder serve --policy P --port N`: serve one of our policies in the openpi websocket protocol, so that
`maniladder eval --policy openpi://HOST:N` (or any openpi client) evaluates it remotely (wire: `remote`).

Each connection gets a policy instance of its own (a stateful policy is not shared by two clients: `--workers K`
opens K connections); the server loads one at start (to check the spec and build its metadata) and more as
connections come. The policy is called in a thread, so the connection keeps answering pings during a long call.
Served policies get what the wire carries: `{"sensor_data": {cam: {"rgb": uint8 (1, H, W, 3)}}}` as numpy arrays, plus
`{"agent": {"qpos": (1, D)}}` when they declare `obs_mode = "rgb+state"` (joint positions only: no qvel, no `extra`),
and `reset(ctx)` with the episode context the client sends (`maniladder/...` keys) before each episode.
"""

from __future__ import annotations

import asyncio
import sys
import time
import traceback
from typing import Optional

import numpy as np

from .policies import EpisodeContext, PolicyError, load_policy
from .remote import ACTIONS_KEY, CAMERA_KEY, INSTALL_HINT, PROMPT_KEY, STATE_KEY, as_numpy

SERVABLE_OBS_MODES = (None, "rgb", "rgb+state", "none")


def served_metadata(policy, spec: str) -> dict:
    """The metadata a client gets on connect: what the policy declares (`remote.DECLARED` keys), its name and, if it
    skips tasks (`supports`), the implemented tasks it supports. PolicyError for a policy the wire cannot carry."""
    from maniladder_ms.catalog import default_catalog

    if hasattr(policy, "run_episode"):
        raise PolicyError(f"{spec} drives the env itself (run_episode); only policies called with observations "
                          "(`policy(obs, spec)`) can be served")
    obs_mode = getattr(policy, "obs_mode", None)
    if obs_mode not in SERVABLE_OBS_MODES:
        raise PolicyError(f"{spec} asks for obs_mode {obs_mode!r}; the wire carries camera images and joint positions "
                          f"only, so a served policy uses one of {', '.join(map(str, SERVABLE_OBS_MODES[1:]))}")
    if hasattr(policy, "env_kwargs"):
        raise PolicyError(f"{spec} sets env_kwargs per task, which the connection metadata cannot declare; give it "
                          "fixed control_mode / cameras / image_size attributes to serve it")
    meta = {"server": "maniladder", "policy": spec, "images": obs_mode != "none", "state": obs_mode == "rgb+state"}
    for key in ("control_mode", "image_size", "cameras"):
        value = getattr(policy, key, None)
        if value:
            meta[key] = list(value) if key == "cameras" else value
    if hasattr(policy, "supports"):
        meta["tasks"] = [t.id for t in default_catalog().filter(implemented=True) if policy.supports(t) is True]
    return meta


class ServedEpisodes:
    """One connection's policy: rebuilds each wire observation (module doc) and resets the policy when a new episode
    begins (another task, episode or seed, or step 0)."""

    def __init__(self, policy):
        self.policy = policy
        self.obs_mode = getattr(policy, "obs_mode", None) or "rgb"
        self._episode = None
        self._ctx: Optional[EpisodeContext] = None

    def act(self, msg: dict) -> np.ndarray:
        import gymnasium as gym

        from maniladder_ms.catalog import default_catalog

        if not isinstance(msg, dict) or "maniladder/task" not in msg:
            got = sorted(msg)[:8] if isinstance(msg, dict) else type(msg).__name__
            raise PolicyError(f"not a ManiLadder observation (no maniladder/task key; got {got}): this server serves "
                              "`maniladder eval --policy openpi://HOST:PORT`")
        spec = default_catalog().get(str(msg["maniladder/task"]))
        episode = (spec.id, int(msg["maniladder/episode"]), int(msg["maniladder/seed"]))
        low = np.asarray(msg["maniladder/action_low"], dtype=np.float32)
        if episode != self._episode or int(msg["maniladder/step"]) == 0:
            self._ctx = EpisodeContext(
                spec=spec, seed=episode[2], episode=episode[1], horizon=int(msg["maniladder/horizon"]),
                action_space=gym.spaces.Box(low, np.asarray(msg["maniladder/action_high"], dtype=np.float32)),
                obs_mode=self.obs_mode, control_mode=str(msg["maniladder/control_mode"]), instruction=str(msg[PROMPT_KEY]))
            self._episode = episode
            if hasattr(self.policy, "reset"):
                self.policy.reset(self._ctx)
        prefix = CAMERA_KEY.format("")
        obs = {"sensor_data": {k[len(prefix):]: {"rgb": np.asarray(v)[None]} for k, v in msg.items()
                               if k.startswith(prefix) and k != STATE_KEY}, "sensor_param": {}}
        if STATE_KEY in msg:
            obs["agent"] = {"qpos": np.asarray(msg[STATE_KEY])[None]}
        # as the policy returned it, as a chunk: the client checks it against its env's action space
        actions = np.asarray(as_numpy(self.policy(obs, spec)), dtype=np.float32)
        return actions[0] if actions.ndim == 3 and actions.shape[0] == 1 else actions[None] if actions.ndim == 1 else actions


class PolicyServer:
    """Serves `policy_spec` (any `--policy` string a process can load) on ws://host:port."""

    def __init__(self, policy_spec: str, host: str = "127.0.0.1", port: int = 8000):
        self.policy_spec, self.host, self.port = policy_spec, host, port
        first = load_policy(policy_spec)
        self.metadata = served_metadata(first, policy_spec)
        self._idle = [first]  # policy instances no connection uses

    async def _handler(self, ws):
        import websockets
        from openpi_client import msgpack_numpy

        policy = self._idle.pop() if self._idle else await asyncio.to_thread(load_policy, self.policy_spec)
        episodes = ServedEpisodes(policy)
        try:
            await ws.send(msgpack_numpy.packb(self.metadata))
            async for frame in ws:
                t0 = time.perf_counter()
                try:
                    actions = await asyncio.to_thread(episodes.act, msgpack_numpy.unpackb(frame))
                except Exception:  # the client gets the traceback as a text frame (openpi's convention)
                    await ws.send(traceback.format_exc())
                    await ws.close(websockets.frames.CloseCode.INTERNAL_ERROR, "policy error; traceback in the previous frame")
                    return
                reply = {ACTIONS_KEY: actions, "server_timing": {"infer_ms": 1000 * (time.perf_counter() - t0)}}
                await ws.send(msgpack_numpy.packb(reply))
        except websockets.ConnectionClosed:
            pass
        finally:
            self._idle.append(policy)

    async def serve(self, ready=None):
        from websockets.asyncio.server import serve

        async with serve(self._handler, self.host, self.port, compression=None, max_size=None) as server:
            port = server.sockets[0].getsockname()[1]
            if ready is not None:
                ready(port)
            await server.serve_forever()


def cmd_serve(args) -> int:
    try:
        import openpi_client  # noqa: F401
        import websockets  # noqa: F401
    except ImportError as e:
        raise PolicyError(f"serving needs openpi-client and websockets ({e}); install the extra: {INSTALL_HINT}") from None
    import maniladder_ms  # noqa: F401  (registers the envs)

    server = PolicyServer(args.policy, args.host, args.port)

    def ready(port):
        m = server.metadata
        declared = ", ".join(f"{k} {m[k]}" for k in ("control_mode", "image_size", "cameras", "state") if k in m)
        print(f"serving {args.policy} on ws://{args.host}:{port} ({declared or 'no declarations'}); "
              f"evaluate it with: maniladder eval --policy openpi://{args.host}:{port}", flush=True)

    try:
        asyncio.run(server.serve(ready))
    except KeyboardInterrupt:
        pass
    except OSError as e:  # the port is taken, the address is not this machine's
        raise PolicyError(f"cannot listen on {args.host}:{args.port} ({e}); pick another --port or --host") from None
    return 0


def add_parser(subparsers) -> None:
    sv = subparsers.add_parser(
        "serve", help="serve a policy over a websocket (openpi protocol) for `eval --policy openpi://HOST:PORT`",
        description="Serve one of our policies in the openpi websocket protocol (docs/remote-policies.md).")
    sv.add_argument("--policy", required=True, help="any --policy of `maniladder eval` that is called with observations")
    sv.add_argument("--port", type=int, default=8000, help="TCP port (default 8000; 0: any free port, printed)")
    sv.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1; 0.0.0.0: every interface)")
    from .cli import _guarded

    sv.set_defaults(func=_guarded(cmd_serve))


if __name__ == "__main__":
    import argparse

    p = argparse.ArgumentParser(prog="maniladder")
    add_parser(p.add_subparsers(dest="command", required=True))
    a = p.parse_args(["serve", *sys.argv[1:]])
    sys.exit(a.func(a))
