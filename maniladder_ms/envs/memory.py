"""Episode memory: what a success rule needs to know about the episode so far, as env state.

Rules such as "handed over" (held by the giver, later by the taker alone), "never touched the table",
"in order", "static for 2 s", "turned >= 720 deg" or "while pressed" read history, not just the current
scene. A task declares its fields once (`EpisodeMemory.flag / counter / value`, in `_load_scene`),
updates them in `ManiLadderEnv._update_memory` (called once after every control step, after the physics;
values known at reset, a start pose, are `store`d at the end of `_initialize_episode`), and reads them in
`evaluate`. The fields are per sub-scene tensors, reset
with the episode, and part of the env state: `get_state_dict` holds them as `memory_<name>`, so
`set_state_dict`, ManiSkill's `replay_trajectory --use-env-states` and recorded demos carry them.
"""

from __future__ import annotations

from typing import Optional

import torch

KINDS = ("flag", "counter", "value")


class EpisodeMemory:
    """Named (num_envs, dim) float tensors: latched flags (0/1), step counters and stored values."""

    def __init__(self, num_envs: int, device):
        self.num_envs, self.device = num_envs, device
        self._fields: dict[str, torch.Tensor] = {}
        self._kinds: dict[str, str] = {}
        self._initial: dict[str, torch.Tensor] = {}

    # ---- declaring --------------------------------------------------------------------------------
    def _declare(self, name: str, kind: str, initial: torch.Tensor):
        if name in self._fields:
            raise ValueError(f"episode memory field {name!r} declared twice")
        self._kinds[name] = kind
        self._initial[name] = initial.to(self.device, torch.float32).reshape(1, -1)
        self._fields[name] = self._initial[name].repeat(self.num_envs, 1)

    def flag(self, name: str, initial: bool = False):
        """A latched flag: `latch(name, cond)` sets it where `cond` holds; only a reset clears it."""
        self._declare(name, "flag", torch.tensor([float(initial)]))

    def counter(self, name: str):
        """A step counter: `count(name, cond)` adds one where `cond` holds (and with `consecutive`, zeroes
        it where it does not)."""
        self._declare(name, "counter", torch.zeros(1))

    def value(self, name: str, dim: int = 1, initial: float = 0.0):
        """A stored value of `dim` floats (a start pose, the last angle): set with `store`."""
        self._declare(name, "value", torch.full((dim,), float(initial)))

    # ---- reading and updating ---------------------------------------------------------------------
    def __contains__(self, name: str) -> bool:
        return name in self._fields

    def names(self) -> list[str]:
        return list(self._fields)

    def __getitem__(self, name: str) -> torch.Tensor:
        """The field: flags as (num_envs,) bool, counters as (num_envs,) int, values as (num_envs, dim)."""
        value = self._fields[self._known(name)]
        kind = self._kinds[name]
        if kind == "flag":
            return value[:, 0] > 0.5
        if kind == "counter":
            return value[:, 0].round().long()
        return value

    def _known(self, name: str) -> str:
        if name not in self._fields:
            raise KeyError(f"no episode memory field {name!r}; declared: {', '.join(self._fields) or 'none'}")
        return name

    def latch(self, name: str, cond: torch.Tensor):
        self._check_kind(name, "flag")
        self._fields[name][:, 0] = torch.where(cond.bool(), 1.0, self._fields[name][:, 0])

    def count(self, name: str, cond: torch.Tensor, consecutive: bool = False):
        self._check_kind(name, "counter")
        field = self._fields[name][:, 0]
        cond = cond.bool()
        self._fields[name][:, 0] = torch.where(cond, field + 1, torch.zeros_like(field) if consecutive else field)

    def store(self, name: str, value: torch.Tensor, env_idx: Optional[torch.Tensor] = None):
        """Set a value field for the sub-scenes `env_idx` (default: all); `value` is (len(env_idx), dim)."""
        self._check_kind(name, "value")
        idx = torch.arange(self.num_envs, device=self.device) if env_idx is None else env_idx
        self._fields[name][idx] = torch.as_tensor(value, dtype=torch.float32, device=self.device).reshape(len(idx), -1)

    def _check_kind(self, name: str, kind: str):
        if self._kinds[self._known(name)] != kind:
            raise TypeError(f"episode memory field {name!r} is a {self._kinds[name]}, not a {kind}")

    # ---- episode and state ------------------------------------------------------------------------
    def reset(self, env_idx: torch.Tensor):
        for name, field in self._fields.items():
            field[env_idx] = self._initial[name]

    STATE_PREFIX = "memory_"

    def state_fields(self):
        """(state key, current value (num_envs, dim), setter(value, env_idx)) per field, in declaration order."""
        for name in self._fields:
            yield self.STATE_PREFIX + name, self._fields[name].clone(), self._setter(name)

    def _setter(self, name: str):
        def set_field(value: torch.Tensor, env_idx: torch.Tensor):
            value = torch.as_tensor(value, dtype=torch.float32, device=self.device).reshape(len(env_idx), -1)
            self._fields[name][env_idx] = value

        return set_field


def latch_held_by_both(env, flag: str, parts: list) -> None:
    """Latch the memory flag `flag` of `env` (a two-arm ManiLadderEnv) where its left and its right end effector
    each hold (`ee.holds`) one of `parts` (actors, links, cloth particles) at this step: an object taken by
    both arms at once (a towel by two corners). The right side's contact queries run only where the left holds
    one; once latched everywhere, nothing is queried."""
    if env.memory[flag].all():
        return
    left = env.ee.holds(parts, "left")
    if left.any():
        env.memory.latch(flag, left & env.ee.holds(parts, "right"))
