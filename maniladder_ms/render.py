"""One picture of a task: every camera of the env side by side, labelled."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

RENDER_CAMERA_SIZE = 256


def camera_images(env) -> dict[str, np.ndarray]:
    """RGB uint8 image of every sensor camera of the (first) sub-env, in rig order."""
    base = env.unwrapped
    base.scene.update_render()
    base.capture_sensor_data()
    images = base.get_sensor_images()
    return {uid: data["rgb"][0].cpu().numpy() for uid, data in images.items() if "rgb" in data}


def tile(images: dict[str, np.ndarray], title: str = "") -> Image.Image:
    """Lay the images out in one row with their names underneath."""
    label_h, title_h = 18, (22 if title else 0)
    h = max(im.shape[0] for im in images.values())
    w = sum(im.shape[1] for im in images.values())
    canvas = Image.new("RGB", (w, h + label_h + title_h), "white")
    draw = ImageDraw.Draw(canvas)
    if title:
        draw.text((6, 4), title, fill="black")
    x = 0
    for name, im in images.items():
        canvas.paste(Image.fromarray(im), (x, title_h))
        draw.text((x + 6, title_h + h + 3), name, fill="black")
        x += im.shape[1]
    return canvas


def save_tiled(images: dict[str, np.ndarray], title: str, out: Path) -> Path:
    """`tile` the images under `title` and write them as a PNG at `out` (folders created)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tile(images, title).save(out)
    return out


def render_task(task_id: str, seed: int, out: Path, domain_randomization: bool = False,
                size: int = RENDER_CAMERA_SIZE, visual_seed: int | None = None, solved: bool = False) -> Path:
    """Every camera of episode `seed`; with domain randomisation in look `visual_seed` (default: the seed's).
    `solved`: at the last step of the task's scripted solver on that episode (the result a demo reaches), not
    at the reset; the title says whether it succeeded."""
    import maniladder_ms

    make_kwargs = dict(obs_mode="rgb", domain_randomization=domain_randomization,
                       sensor_configs=dict(width=size, height=size))
    if solved:
        from maniladder_ms.solvers import solve, solver_for

        if visual_seed is not None:
            raise ValueError("a solved render replays the --seed episode in its own look: drop --visual-seed")
        # the solver's own control mode; state observations (the cameras are rendered once, at the end)
        make_kwargs.update(obs_mode="state", control_mode=solver_for(task_id).control_mode)
    env = maniladder_ms.make(task_id, **make_kwargs)
    try:
        if solved:
            outcome = f", after the scripted solver: success {bool(solve(env, seed)['success'][0])}"
        else:
            env.reset(seed=seed, options=None if visual_seed is None else {"visual_seed": visual_seed})
            outcome = ""
        spec = env.unwrapped.task_spec
        look = f", domain randomisation, visual seed {env.unwrapped.visual_seed}" if domain_randomization else ""
        title = f"{spec.id}  ({spec.suite}, seed {seed}{look}{outcome})"
        return save_tiled(camera_images(env), title, out)
    finally:
        env.close()


def render_agent(uid: str, seed: int, out: Path, size: int = RENDER_CAMERA_SIZE) -> Path:
    """The agent at rest in the empty scene beside a 5 cm cube: every camera, plus a close-up of each hand."""
    import gymnasium as gym
    from mani_skill.utils import sapien_utils

    import maniladder_ms  # noqa: F401  (registers the agents and the gallery)

    env = gym.make("ManiLadder-AgentGallery-v1", robot_uids=uid, obs_mode="rgb", test_object="cube",
                   render_mode="rgb_array", robot_init_qpos_noise=0.0,
                   sensor_configs=dict(width=size, height=size), human_render_camera_configs=dict(width=size, height=size))
    try:
        env.reset(seed=seed)
        base = env.unwrapped
        images = camera_images(env)
        agent = base.agent
        tcps = agent.tcps if hasattr(agent, "tcps") else {"hand": agent.tcp}
        camera = base.scene.human_render_cameras["render_camera"].camera
        for side, tcp in tcps.items():
            # the hand's middle: the tcp of a LEAP hand lies 15 cm out from the flange, a gripper's 10 cm
            target = tcp.pose.p[0].cpu().numpy() + np.array([0.0, 0.0, 0.06 if "leap" in uid else 0.03])
            # from the front-right and below: palm, fingers and thumb in view
            camera.set_local_pose(sapien_utils.look_at(target + np.array([0.2, -0.15, -0.1]), target).sp)
            base.scene.update_render()
            images[f"{side} close-up"] = base.render()[0].cpu().numpy()
        return save_tiled(images, f"agent {uid} (rest pose, seed {seed})", out)
    finally:
        env.close()
