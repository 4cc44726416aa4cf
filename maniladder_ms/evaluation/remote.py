"""Policies served over a websocket in the openpi protocol: `--policy openpi://HOST:PORT[?key=value&...]`.

The wire (openpi's `WebsocketPolicyServer` / `openpi_client.WebsocketClientPolicy`): the client connects, the
server sends its metadata (one msgpack dict), then every call is one msgpack frame each way (numpy arrays packed
by `openpi_client.msgpack_numpy`): an observation dict out, a dict with `actions` back. A text frame back is the
server's error (a traceback).

Observation keys (`observation_message`):

    observation/<camera uid>   uint8 (H, W, 3), one per camera the policy sees (e.g. observation/front_camera)
    observation/state          float32 (D,): the robot's joint positions (qpos), only when the policy declares `state`
    prompt                     str: the episode's language instruction (`EpisodeContext.instruction`)
    maniladder/task, maniladder/episode, maniladder/seed, maniladder/step   the task id, the episode index, its
                               seed and the control step the observation is taken at (0 at reset)
    maniladder/control_mode, maniladder/horizon, maniladder/action_low, maniladder/action_high   the episode's
                               control mode, horizon and action bounds (float32 (A,))

Reply: `{"actions": float32 (H, A), ...}`, a chunk of H >= 1 actions in the declared control mode, executed open loop
(the policy is called again when the chunk is used up); other keys (openpi's `server_timing`) are ignored.

What the policy needs comes from the server's metadata, overridden by the spec's query (`?control_mode=pd_ee_delta_pose
&state=1&image_size=224&cameras=front_camera&timeout=60`): `control_mode` (default: the env's default,
`pd_joint_delta_pos`), `image_size` (square camera images; default the cameras' 128), `cameras` (default: the run's
`--cameras`, or every camera of the task), `state` (send `observation/state`; default no), `images` (default yes; no:
the policy ignores images and none are rendered). `timeout` (seconds per call, default 60) is the client's own.

openpi-client is imported here only, when a spec is loaded (`pip install 'maniladder-ms[remote]'`).
"""

from __future__ import annotations

import urllib.parse
from typing import Optional

import numpy as np

from .policies import EpisodeContext, PolicyError

SCHEME = "openpi://"
DEFAULT_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_S = 30.0
INSTALL_HINT = "pip install 'maniladder-ms[remote]'"
# metadata / query keys a server may declare, and how each is read
DECLARED = {"control_mode": str, "image_size": int, "cameras": "list", "state": "bool", "images": "bool"}
QUERY_KEYS = (*DECLARED, "timeout")
CAMERA_KEY = "observation/{}"
STATE_KEY = "observation/state"
PROMPT_KEY = "prompt"
ACTIONS_KEY = "actions"


class RemotePolicyError(PolicyError):
    """A remote policy that cannot be reached, times out, drops the connection or answers out of contract."""


def _as_bool(value, where: str) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "true", "yes", "on"):
        return True
    if text in ("0", "false", "no", "off"):
        return False
    raise RemotePolicyError(f"{where}: expected a boolean (1/0, true/false), got {value!r}")


def read_declared(values: dict, where: str) -> dict:
    """The known keys of `values` (server metadata or spec query) converted; unknown keys are left out."""
    out = {}
    for key, kind in DECLARED.items():
        if key not in values or values[key] is None:
            continue
        value = values[key]
        try:
            if kind == "bool":
                value = _as_bool(value, f"{where} {key}")
            elif kind == "list":
                value = tuple(c.strip() for c in value.split(",") if c.strip()) if isinstance(value, str) else tuple(map(str, value))
            else:
                value = kind(value)
        except (TypeError, ValueError) as e:
            raise RemotePolicyError(f"{where}: {key}={values[key]!r} is not a valid {key} ({e})") from None
        out[key] = value
    return out


def parse_spec(spec: str) -> tuple[str, int, dict, float]:
    """(host, port, declared query values, timeout in s) of `openpi://HOST:PORT[?key=value&...]`."""
    if not spec.startswith(SCHEME):
        raise RemotePolicyError(f"{spec!r} is not a remote policy (expected {SCHEME}HOST:PORT)")
    url = urllib.parse.urlsplit("ws://" + spec[len(SCHEME):])
    try:
        port = url.port
    except ValueError:
        port = None
    if not url.hostname or port is None or url.path not in ("", "/"):
        raise RemotePolicyError(f"{spec!r}: expected {SCHEME}HOST:PORT[?key=value&...], e.g. {SCHEME}127.0.0.1:8000")
    query = dict(urllib.parse.parse_qsl(url.query, keep_blank_values=True))
    unknown = sorted(set(query) - set(QUERY_KEYS))
    if unknown:
        raise RemotePolicyError(f"{spec!r}: unknown option(s) {unknown}; known: {', '.join(QUERY_KEYS)}")
    try:
        timeout = float(query.pop("timeout", DEFAULT_TIMEOUT_S))
    except ValueError:
        raise RemotePolicyError(f"{spec!r}: timeout must be a number of seconds") from None
    if timeout <= 0:
        raise RemotePolicyError(f"{spec!r}: timeout must be > 0 seconds")
    return url.hostname, port, read_declared(query, f"{spec!r}"), timeout


def spec_identity(spec: str) -> str:
    """`spec` as a results folder records it: without the client's `timeout`, which changes no episode (a run
    stopped by a timeout resumes with a longer one); the declarations, which do, stay (sorted)."""
    base, _, query = spec.partition("?")
    kept = sorted((k, v) for k, v in urllib.parse.parse_qsl(query, keep_blank_values=True) if k != "timeout")
    return base + ("?" + urllib.parse.urlencode(kept, safe=",") if kept else "")


def _client_class():
    """openpi-client's `WebsocketClientPolicy`, connecting without keepalive pings: a call's time limit is the
    client's `timeout`, and an evaluation process busy building a scene for a while (GIL held) must not lose the
    connection for a late pong."""
    try:
        import websockets.sync.client
        from openpi_client import msgpack_numpy
        from openpi_client.websocket_client_policy import WebsocketClientPolicy
    except ImportError as e:
        raise PolicyError(f"remote policies need openpi-client ({e}); install the extra: {INSTALL_HINT}") from None

    class Client(WebsocketClientPolicy):
        def _wait_for_server(self):
            conn = websockets.sync.client.connect(self._uri, compression=None, max_size=None, ping_interval=None,
                                                  open_timeout=CONNECT_TIMEOUT_S)
            return conn, msgpack_numpy.unpackb(conn.recv(timeout=CONNECT_TIMEOUT_S))

    return Client, msgpack_numpy


def observation_message(obs, ctx: EpisodeContext, step: int, state: bool) -> dict:
    """The wire observation (module doc) of one batched env observation (batch size 1)."""
    msg = {}
    for cam, data in (obs.get("sensor_data") or {}).items() if isinstance(obs, dict) else ():
        if "rgb" in data:
            msg[CAMERA_KEY.format(cam)] = np.ascontiguousarray(as_numpy(data["rgb"])[0], dtype=np.uint8)
    if state:
        msg[STATE_KEY] = np.asarray(as_numpy(obs["agent"]["qpos"])[0], dtype=np.float32)
    space = ctx.action_space
    msg.update({
        PROMPT_KEY: ctx.instruction,
        "maniladder/task": ctx.spec.id, "maniladder/episode": int(ctx.episode), "maniladder/seed": int(ctx.seed),
        "maniladder/step": int(step), "maniladder/control_mode": ctx.control_mode, "maniladder/horizon": int(ctx.horizon),
        "maniladder/action_low": np.asarray(space.low, dtype=np.float32),
        "maniladder/action_high": np.asarray(space.high, dtype=np.float32),
    })
    return msg


def as_numpy(x) -> np.ndarray:
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    return np.asarray(x)


class RemotePolicy:
    """A policy served in the openpi protocol (module doc); loaded by `load_policy("openpi://HOST:PORT")`."""

    def __init__(self, spec: str):
        self.name = spec
        self.host, self.port, query, self.timeout = parse_spec(spec)
        self.uri = f"ws://{self.host}:{self.port}"
        self._client_class, self._msgpack = _client_class()
        self._client = self._connect()
        metadata = self._client.get_server_metadata()
        self.metadata = metadata if isinstance(metadata, dict) else {}
        declared = {**read_declared(self.metadata, f"{self.uri} metadata"), **query}
        self.control_mode: Optional[str] = declared.get("control_mode")
        self.image_size: Optional[int] = declared.get("image_size")
        self.cameras: Optional[tuple] = declared.get("cameras") or None
        self.state: bool = declared.get("state", False)
        images = declared.get("images", True)
        self.obs_mode = ("rgb+state" if self.state else "rgb") if images else ("state_dict" if self.state else "none")
        self._ctx: Optional[EpisodeContext] = None
        self._step = 0
        self.calls = 0

    def _connect(self):
        try:
            return self._client_class(self.host, self.port)
        except (OSError, TimeoutError) as e:
            raise RemotePolicyError(
                f"no policy server at {self.uri} ({type(e).__name__}: {e}); start one (`maniladder serve --policy P "
                f"--port {self.port}`, or an openpi policy server) and check the host and port") from None
        except Exception as e:  # a handshake refused (not a websocket server), a bad first frame
            raise RemotePolicyError(f"{self.uri} did not answer as an openpi policy server ({type(e).__name__}: {e})") from None

    def close(self):
        ws = getattr(self._client, "_ws", None)
        if ws is not None:
            ws.close()

    def supports(self, spec):
        tasks = self.metadata.get("tasks")  # a server may list the tasks it serves (`maniladder serve` does)
        return True if tasks is None or spec.id in tasks else f"the policy served at {self.uri} does not support {spec.id}"

    def reset(self, ctx: EpisodeContext):
        self._ctx = ctx
        self._step = 0
        self._client.reset()

    def _where(self, spec) -> str:
        seed = self._ctx.seed if self._ctx is not None else "?"
        return f"task {spec.id}, step {self._step + 1} (seed {seed}): remote policy {self.uri}"

    def infer(self, message: dict, where: str) -> dict:
        """One call: send `message`, wait at most `timeout` s for the reply (RemotePolicyError naming `where`)."""
        from websockets.exceptions import ConnectionClosed

        for attempt in (1, 2):
            ws = self._client._ws  # openpi-client's connection: its own `infer` waits without a time limit
            try:
                ws.send(self._msgpack.packb(message))
                reply = ws.recv(timeout=self.timeout)
                break
            except TimeoutError:
                ws.close()  # a late reply must not answer the next call
                raise RemotePolicyError(f"{where}: no reply within {self.timeout:g} s (timeout; raise it with "
                                        f"{SCHEME}{self.host}:{self.port}?timeout=SECONDS)") from None
            except ConnectionClosed as e:
                if attempt == 1 and self._step == 0:
                    # closed before an episode's first call (e.g. a server's keepalive ran out while this process
                    # built a scene): no episode state is lost, so a new connection takes the call
                    try:
                        self._client = self._connect()
                        continue
                    except RemotePolicyError as again:
                        raise RemotePolicyError(f"{where}: the connection dropped and {again}") from None
                raise RemotePolicyError(f"{where}: the connection dropped ({e}); the finished episodes are kept: "
                                        "restart the server and re-run the same command to resume") from None
            except OSError as e:
                raise RemotePolicyError(f"{where}: the connection failed ({type(e).__name__}: {e}); re-run the same "
                                        "command to resume") from None
        if isinstance(reply, str):
            raise RemotePolicyError(f"{where}: the server failed:\n{reply.strip()}")
        out = self._msgpack.unpackb(reply)
        if not isinstance(out, dict) or ACTIONS_KEY not in out:
            keys = sorted(out) if isinstance(out, dict) else type(out).__name__
            raise RemotePolicyError(f"{where}: the reply has no {ACTIONS_KEY!r} (got {keys})")
        return out

    def __call__(self, obs, spec):
        if self._ctx is None or self._ctx.spec.id != spec.id:
            raise RemotePolicyError(f"task {spec.id}: the remote policy was called before reset(ctx)")
        where = self._where(spec)
        reply = self.infer(observation_message(obs, self._ctx, self._step, self.state), where)
        try:
            actions = np.asarray(reply[ACTIONS_KEY], dtype=np.float32)
        except (TypeError, ValueError) as e:
            raise RemotePolicyError(f"{where}: the reply's {ACTIONS_KEY!r} is not an array of numbers ({e})") from None
        dim = int(self._ctx.action_space.shape[0])
        if actions.ndim == 1 and actions.shape[0] == dim:
            actions = actions[None]
        if actions.ndim != 2 or actions.shape[1] != dim or actions.shape[0] < 1:
            raise RemotePolicyError(
                f"{where}: the server returned actions of shape {tuple(actions.shape)}; the env's action space in "
                f"control mode {self._ctx.control_mode} is {dim}-D, so a chunk must be (H, {dim}). Declare the mode "
                f"the server acts in: its metadata key control_mode, or {SCHEME}{self.host}:{self.port}"
                f"?control_mode=MODE")
        self._step += actions.shape[0]
        self.calls += 1
        return actions

