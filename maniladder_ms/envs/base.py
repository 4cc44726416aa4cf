"""`ManiLadderEnv`: the base every ManiLadder task subclasses.

It owns what all tasks share: the catalog metadata of the task, the table-top scene (with optional
domain randomisation), the camera rig (front, left and top third-view cameras plus the robot's
wrist cameras), robot placement and rest pose, supported-robot checks and the render-backend choice.
Tasks add their objects in `_load_scene`, randomise them in `_initialize_episode` (after calling
super), and define `evaluate` and the dense rewards, as ManiSkill tasks do.

What every task's rule, reward and solver use:
- `self.params`: the task's numbers (sizes, tolerances, counts) from its catalog row's `params`, also set as
  attributes (`self.margin`); a family class lists the names it reads in `PARAMS`, one class serving every
  catalog row of its family;
- `self.ee`: the end-effector vocabulary (`agents.effectors.EndEffectors`: `sides`, `tcp(side)`,
  `holds(obj, side)`, `touches(obj, side)`, `is_open(side)`), the same for all five agents;
- `self.memory`: episode memory (`envs.memory.EpisodeMemory`: latched flags, counters, stored values),
  updated in `_update_memory` after every control step and part of the env state.
"""

from __future__ import annotations

import glob
import os
from contextlib import contextmanager
from typing import Any, ClassVar, Optional, Sequence

import numpy as np
import sapien
import torch

from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils

from maniladder_ms.agents.effectors import EndEffectors, mark_placed, mark_simulated
from maniladder_ms.agents.robots import offered_control_modes
from maniladder_ms.catalog import CatalogError, TaskSpec, default_catalog

from .memory import EpisodeMemory
from .scene import LadderScene

ROBOT_BASE_POSE = sapien.Pose(p=[-0.615, 0, 0])
CAMERA_SIZE = 128
VISUAL_OBS_MODES = ("rgb", "rgbd", "depth", "pointcloud", "sensor_data", "segmentation")
LAVAPIPE_ICD_GLOB = "/usr/share/vulkan/icd.d/lvp_icd*.json"


class UnsupportedRobotError(ValueError):
    """A robot uid the task was not built for."""


class UnsupportedControlModeError(ValueError):
    """A control mode the task's robot does not offer."""


def _check_visual_seed(seed) -> Optional[int]:
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**32:
        raise ValueError(f"visual_seed must be an int in [0, 2**32), got {seed!r}")
    return int(seed)


def _needs_rendering(obs_mode: Optional[str], render_mode: Optional[str]) -> bool:
    return render_mode is not None or any(m in (obs_mode or "") for m in VISUAL_OBS_MODES)


def resolve_render_backend(requested: Optional[str], obs_mode: Optional[str], render_mode: Optional[str]) -> str:
    """GPU if there is one, else CPU lavapipe if installed, else none (state obs only).

    `requested` (the env kwarg) or `$MANILADDER_RENDER_BACKEND` override the choice.
    """
    backend = requested or os.environ.get("MANILADDER_RENDER_BACKEND")
    if backend is None:
        if torch.cuda.is_available():
            backend = "gpu"
        elif glob.glob(LAVAPIPE_ICD_GLOB):
            backend = "cpu"
        else:
            backend = "none"
    if backend in ("none", "sapien_none") and _needs_rendering(obs_mode, render_mode):
        raise RuntimeError(
            f"obs_mode={obs_mode!r} / render_mode={render_mode!r} need a renderer, but no GPU and no software "
            "Vulkan (Mesa lavapipe >= 24.3) was found. Run scripts/setup.sh, or pass render_backend='cpu'/'gpu'."
        )
    return backend


class ManiLadderEnv(BaseEnv):
    """Base class of all ManiLadder tasks (see the module docstring).

    Keyword args beyond ManiSkill's BaseEnv:
        task_id: catalog id, fixed by the registration of each env id; None for scenes that are not
            ladder tasks (agent gallery, deformable showcases), whose `task_spec` is then None.
        domain_randomization: randomise lighting, table/backdrop textures and 0-3 distractors; the
            scene is then rebuilt at every reset (reconfiguration_freq=1). The randomisation draws from
            its own generators, never from the episode RNGs: a seed gives the same task layout (every
            object pose and task parameter) with randomisation on or off, whatever the look.
        visual_seed: the seed of the look (textures, lighting, distractors) of every episode; default
            None: each episode's own seed, so a seed still fixes the whole randomised scene. A reset
            option overrides it for one episode: `env.reset(seed=3, options={"visual_seed": 7})` is
            episode 3 with look 7 (same episode, new look). Ignored without domain randomisation.
        robot_init_qpos_noise: std of the noise added to the robot's rest pose at reset.
        cameras: the sensor cameras to capture (uids, e.g. ("front_camera", "left_camera", "top_camera"));
            default all: the three third-view cameras and the robot's wrist cameras. A visual policy
            declares what it sees and renders nothing else.
        fresh_physics_per_seed: a seeded reset (`env.reset(seed=s)`, all sub-scenes) rebuilds the scene, so the
            episode starts from fresh PhysX: contact warm-start caches, which are not env state, otherwise
            carry over from earlier episodes, and the same seed and actions end differently after another
            episode (measured: a HangTowelOnBar demo that succeeds alone fails after one other episode; ManiSkill's
            seeded-sequence-reset check differed by up to 1.4 on CupBeansHands). An episode is then a function of
            (task, seed, actions) alone, whatever ran before it. Cost: ~0.25-0.3 s a reset with state obs,
            ~0.3-0.5 s with the three cameras (measured on 5 tasks, 2-core CPU; an episode is 2-40 s). Unseeded
            resets (RL rollouts) keep the scene. False: never rebuild on a seeded reset.
    """

    SUPPORTED_ROBOTS: ClassVar[list[str]] = ["ml_panda", "panda_wristcam"]
    # (xmin, xmax, ymin, ymax) of the table area task objects and goals use; distractors stay out of it. It
    # covers every task object's extent at reset (within scene.KEEP_OUT_MARGIN - scene.DISTRACTOR_REACH; test
    # test_task_objects_stay_in_the_task_region), so no distractor touches one
    TASK_REGION: ClassVar[tuple[float, float, float, float]] = (-0.25, 0.25, -0.3, 0.3)
    task_spec: Optional[TaskSpec]
    # the dense reward a task gives on success: the normalized dense reward is the dense one over this
    max_dense_reward: ClassVar[float] = 1.0
    # True where PhysX data kept outside the env state (contact caches) makes two restores of one state
    # into a scene that simulated on part ways (many persistent contacts: clay, particle piles); state
    # checks then restore into freshly built scenes, which agree exactly
    RESTORES_NEED_FRESH_SCENE: ClassVar[bool] = False
    # joint name -> angle overriding the agent's rest keyframe at reset: a task whose grasps need the hands
    # turned far from the rest pose starts them ready (servoing a ~180 deg wrist turn from rest lands the
    # IK on a wrong branch on some seeds)
    READY_JOINTS: ClassVar[dict[str, float]] = {}
    # the names of the catalog `params` a task (family) class reads: its catalog row must give exactly these
    PARAMS: ClassVar[tuple[str, ...]] = ()
    # third-view cameras, uid -> (eye, target) in world metres, and the human render camera's (eye, target):
    # a task whose scene reaches past the table (a mobile task's second table) widens them, keeping the uids
    CAMERA_VIEWS: ClassVar[dict[str, tuple]] = {
        "front_camera": ([0.55, 0, 0.45], [-0.1, 0, 0.05]),
        "left_camera": ([-0.1, 0.7, 0.45], [-0.1, 0, 0.05]),
        "top_camera": ([-0.05, 0, 0.95], [-0.0, 0, 0]),
    }
    RENDER_VIEW: ClassVar[tuple] = ([0.6, 0.7, 0.6], [-0.1, 0.0, 0.1])

    def __init__(
        self,
        *args,
        task_id: Optional[str],
        robot_uids: Optional[str] = None,
        domain_randomization: bool = False,
        visual_seed: Optional[int] = None,
        robot_init_qpos_noise: float = 0.02,
        render_backend: Optional[str] = None,
        cameras: Optional[Sequence[str]] = None,
        fresh_physics_per_seed: bool = True,
        **kwargs,
    ):
        self.fresh_physics_per_seed = bool(fresh_physics_per_seed)
        self.cameras = None if cameras is None else tuple(cameras)
        self._sensors_on = True
        self.task_spec = None if task_id is None else default_catalog().get(task_id)
        self.params = self._read_params()
        robot_uids = self.SUPPORTED_ROBOTS[0] if robot_uids is None else robot_uids
        if robot_uids not in self.SUPPORTED_ROBOTS:
            raise UnsupportedRobotError(
                f"{task_id or type(self).__name__} does not support robot {robot_uids!r}; supported: {', '.join(map(str, self.SUPPORTED_ROBOTS))}"
            )
        if kwargs.get("control_mode") is not None:
            modes = offered_control_modes(robot_uids)
            if kwargs["control_mode"] not in modes:
                raise UnsupportedControlModeError(
                    f"{task_id or type(self).__name__}: robot {robot_uids!r} has no control mode "
                    f"{kwargs['control_mode']!r}; it offers: {', '.join(modes)}"
                )
        self.domain_randomization = domain_randomization
        self._visual_seed_default = _check_visual_seed(visual_seed)
        self._visual_seed_option: Optional[int] = None
        # the look's seed of the current scene (None without domain randomisation)
        self.visual_seed: Optional[int] = None
        self.robot_init_qpos_noise = robot_init_qpos_noise
        if domain_randomization:
            kwargs.setdefault("reconfiguration_freq", 1)
        # unseeded resets draw their episode seed from the main RNG and seed torch with it (ManiSkill's option):
        # otherwise their layouts come from torch's global RNG, which whatever else ran in the process moves
        kwargs.setdefault("enhanced_determinism", True)
        render_backend = resolve_render_backend(render_backend, kwargs.get("obs_mode"), kwargs.get("render_mode"))
        super().__init__(*args, robot_uids=robot_uids, render_backend=render_backend, **kwargs)

    def _read_params(self) -> dict:
        """The catalog row's `params`, checked against the class's `PARAMS`, set as attributes."""
        params = {} if self.task_spec is None else dict(self.task_spec.params)
        if self.task_spec is not None and set(params) != set(self.PARAMS):
            missing, unknown = sorted(set(self.PARAMS) - set(params)), sorted(set(params) - set(self.PARAMS))
            raise CatalogError(
                f"catalog row {self.task_spec.id}: params must be exactly what {type(self).__name__} reads "
                f"(missing: {missing or 'none'}; not read by the class: {unknown or 'none'})"
            )
        for name, value in params.items():
            setattr(self, name, tuple(value) if isinstance(value, list) else value)
        return params

    def reset(self, seed=None, options=None):
        """ManiSkill's reset, plus the option `visual_seed` (see the class doc): the look's seed for this
        episode; with domain randomisation a reset given one rebuilds the scene in that look. A seeded reset of
        every sub-scene starts from fresh physics (`fresh_physics_per_seed`, see the class doc)."""
        options = dict(options or {})
        self._visual_seed_option = _check_visual_seed(options.pop("visual_seed", None))
        env_idx = options.get("env_idx")
        partial = env_idx is not None and len(env_idx) < self.num_envs
        if self._visual_seed_option is not None and self.domain_randomization:
            if partial:
                raise ValueError(
                    f"the reset option visual_seed rebuilds every sub-scene in a new look; it cannot go with a "
                    f"partial reset (env_idx: {len(env_idx)} of {self.num_envs} sub-scenes)")
            options["reconfigure"] = True
        if seed is not None and self.fresh_physics_per_seed and not partial:
            options["reconfigure"] = True
        return super().reset(seed=seed, options=options)

    def _resolve_visual_seed(self) -> Optional[int]:
        """The look's seed of a scene being built: the reset option's, the env's, or the episode seed."""
        if not self.domain_randomization:
            return None
        for seed in (self._visual_seed_option, self._visual_seed_default):
            if seed is not None:
                return seed
        return int(self._episode_seed[0])

    # ---- cameras ------------------------------------------------------------------------------
    @property
    def _default_sensor_configs(self):
        return [
            CameraConfig(uid, sapien_utils.look_at(eye=eye, target=tgt), CAMERA_SIZE, CAMERA_SIZE, 1.1, 0.01, 10)
            for uid, (eye, tgt) in self.CAMERA_VIEWS.items()
        ]

    def _setup_sensors(self, options: dict):
        super()._setup_sensors(options)
        if self.cameras is None:
            return
        unknown = sorted(set(self.cameras) - set(self._sensors))
        if unknown:
            raise ValueError(f"unknown camera(s) {unknown}; this env has: {', '.join(self._sensors)}")
        for uid in list(self._sensors):
            if uid not in self.cameras:  # built with the scene, but never captured or returned
                del self._sensors[uid]
                self._sensor_configs.pop(uid, None)
                self._agent_sensor_configs.pop(uid, None)

    @contextmanager
    def sensors_off(self):
        """Steps taken inside render no camera: their obs carry `agent` and `extra` but empty `sensor_data`
        (an action chunk executed open loop needs no images between policy calls)."""
        self._sensors_on = False
        try:
            yield
        finally:
            self._sensors_on = True

    def _get_obs_with_sensor_data(self, info: dict, apply_texture_transforms: bool = True) -> dict:
        if self._sensors_on:
            return super()._get_obs_with_sensor_data(info, apply_texture_transforms)
        return dict(agent=self._get_obs_agent(), extra=self._get_obs_extra(info), sensor_param={}, sensor_data={})

    @property
    def _default_human_render_camera_configs(self):
        pose = sapien_utils.look_at(*self.RENDER_VIEW)
        return CameraConfig("render_camera", pose, 512, 512, 1.0, 0.01, 10)

    # ---- scene --------------------------------------------------------------------------------
    def _load_agent(self, options: dict):
        super()._load_agent(options, ROBOT_BASE_POSE)

    def _load_scene(self, options: dict):
        # the look draws from its own generators (seeded by the visual seed), so the task's layout draws
        # from the episode RNGs after this are the same with and without domain randomisation
        self.visual_seed = self._resolve_visual_seed()
        self.ladder_scene = LadderScene(self, randomize=self.domain_randomization, visual_seed=self.visual_seed)
        self.ladder_scene.build()
        self.ee = EndEffectors(self.agent, self.scene)
        # tasks declare their fields after calling super()._load_scene
        self.memory = EpisodeMemory(self.num_envs, self.device)

    def _load_lighting(self, options: dict):
        self.ladder_scene.load_lighting()

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        """Robot to its rest pose (plus noise) and distractors clear of the task; tasks call this first."""
        with torch.device(self.device):
            b = len(env_idx)
            qpos = torch.as_tensor(self.agent.keyframes["rest"].qpos, dtype=torch.float32).repeat(b, 1)
            active = [joint.name for joint in self.agent.robot.active_joints]
            for name, angle in self.READY_JOINTS.items():
                qpos[:, active.index(name)] = angle
            # noise on the arm joints only: the gripper starts open and a mobile base where it is
            arm = [active.index(name) for name in self.agent.arm_joint_names]
            qpos[:, arm] += torch.randn(b, len(arm)) * self.robot_init_qpos_noise
            self.agent.reset(qpos)
            self.agent.robot.set_pose(ROBOT_BASE_POSE)
            self.ladder_scene.initialize(env_idx, keep_out=self.TASK_REGION)
            self.memory.reset(env_idx)
            self.ee.new_state()
            mark_placed(self.scene, env_idx)  # PhysX's contact list is the previous episode's until a step

    # ---- episode memory and state -----------------------------------------------------------------
    def _update_memory(self):
        """Update `self.memory` from the scene; called once after every control step. Tasks whose rule
        reads history override it (`self.memory.latch(...)`, `count`, `store`)."""

    def _after_simulation_step(self):
        super()._after_simulation_step()
        mark_simulated(self.scene)
        self.ee.new_state()  # contacts and poses changed: `ee`'s cached contact answers are stale

    def _after_control_step(self):
        super()._after_control_step()
        self._update_memory()

    def _extra_state_fields(self):
        """(key, value (num_envs, k), setter(value, env_idx)) of state kept outside PhysX, in state order:
        the episode memory here; subclasses (clay) add theirs after calling super."""
        yield from self.memory.state_fields()

    def get_state_dict(self):
        state = super().get_state_dict()
        for key, value, _ in self._extra_state_fields():
            state[key] = value
        return state

    def set_state_dict(self, state: dict, env_idx: torch.Tensor = None):
        super().set_state_dict(state, env_idx)
        self.ee.new_state()
        idx = torch.arange(self.num_envs, device=self.device) if env_idx is None else env_idx
        for key, _, setter in self._extra_state_fields():
            if key in state:  # states recorded before a field existed leave it as it is
                # (numpy arrays where ManiSkill's replay_trajectory reads states from a demo file)
                setter(torch.as_tensor(state[key], device=self.device), idx)

    def set_state(self, state: torch.Tensor, env_idx: torch.Tensor = None):
        """ManiSkill's flat `set_state` reads only actors and articulations: the extra fields are taken back
        from the end of the vector, where `get_state` (the flattened state dict) puts them."""
        super().set_state(state, env_idx)
        fields = list(self._extra_state_fields())
        state = torch.as_tensor(state)
        if not fields or state.shape[-1] != self.get_state().shape[-1]:
            return  # no extra fields, or not a full flat state of this env
        idx = torch.arange(self.num_envs, device=self.device) if env_idx is None else env_idx
        start = state.shape[-1] - sum(value.shape[1] for _, value, _ in fields)
        for _, value, setter in fields:
            setter(state[..., start:start + value.shape[1]], idx)
            start += value.shape[1]

    # ---- reward -------------------------------------------------------------------------------
    def compute_normalized_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        return self.compute_dense_reward(obs, action, info) / self.max_dense_reward
