"""LadderFlow: the reference policy's network and its training (protocol v4).

A small transformer encoder-decoder that denoises action chunks with flow matching (rectified flow):
- observation: frozen encoder tokens of the front, left and top cameras (no proprioception, no privileged
  state): EfficientNet-Lite0's stride-16 map (8 x 8 cells at 128 px), pooled per camera by 8 learned
  spatial-softmax keypoints (expected cell position + weighted feature), projected to `d_model`, plus learned
  per-token position embeddings;
- action chunk: `chunk` (16) normalised actions, absolute joint targets (`pd_joint_pos`: arm joint angles,
  gripper command or hand joint targets; protocol v1 used end-effector deltas, see `policy.calibrate`);
  training draws t ~ U(0, 1) and noise x0 ~ N(0, I), forms x_t = (1 - t) x0 + t x1 and regresses the velocity
  x1 - x0; inference integrates the predicted velocity from noise with `integration_steps` Euler steps; the
  policy executes the first `execute` (8);
- AdamW, cosine learning rate, an exponential moving average of the weights (the EMA is what acts).

Everything that defines the protocol is `LadderFlowConfig()`'s defaults; a checkpoint carries its config,
the action normaliser and both weight sets, so it acts the same on any machine.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path
from typing import Optional

import torch
from torch import nn

# v4: order-independent evaluation episodes, work keyed by task version, 3 pooled training seeds, one checkpoint
# (no selection), development/final seed sets (`policy.calibrate`); v3's network trained 4000 steps on features
# with random-shift copies (v3: 8000 steps, none). v3: v2 trained 8000 steps, not 3000; v2: absolute joint-target
# actions (v1: end-effector deltas)
PROTOCOL_VERSION = "v4"


@dataclasses.dataclass(frozen=True)
class LadderFlowConfig:
    encoder: str = "efficientnet-lite0-s16"
    cameras: tuple[str, ...] = ("front_camera", "left_camera", "top_camera")
    image_size: int = 128
    grid: int = 2  # encoder tokens per camera: grid x grid (efficientnet-lite0's pooled last map)
    keypoints: int = 8  # > 0: each camera's token map pooled by that many learned spatial-softmax keypoints
    chunk: int = 16  # actions predicted per call
    execute: int = 8  # of which the first ones are executed open loop
    integration_steps: int = 10
    # observation frames the policy sees: the current one and the `history - 1` it observed before it, `execute`
    # steps apart (the frames it acted on); 1: the current frame alone. v4 keeps 1: two frames lost at 2000 steps
    # (LiftBottleHand 7/50 against 10/50, paired, development seeds)
    history: int = 1
    # random-shift augmentation: every demo frame also encoded as `augment_copies` copies shifted by up to
    # `augment_shift` px (`features.random_shift`); training draws the frame or one of its copies. 0: none.
    # v4: 2 copies, by paired measurement at 4000 steps (same demos and 50 development episodes): LiftBottleHand
    # 37/50, PickPlacePen 15/50, DragRopeToGoal 34/50 against 31, 14, 22 without; ~120 CPU s more encoding a task
    augment_copies: int = 2
    augment_shift: int = 8
    # sized for a CPU (measured, one core: ~0.15-0.25 s a step). A GPU runs the same configuration, but its
    # arithmetic differs from the CPU's, so it trains another policy: results record the device
    d_model: int = 128
    heads: int = 4
    encoder_layers: int = 2
    decoder_layers: int = 2
    dropout: float = 0.0
    lr: float = 1e-3
    weight_decay: float = 1e-4
    batch_size: int = 64
    # v4: 4000, v3's 8000 halved, by paired measurement (same demos, features and 50 development episodes, the
    # complete cosine schedule each): LiftBottleHand 31/50 at 4000 against 32/50 at 8000, PickPlacePen 14/50
    # against 10/50; 2000 lost (10/50, 0/50). v3: 8000, not v2's 3000
    train_steps: int = 4000
    ema_decay: float = 0.999
    seed: int = 0

    # fields added after the first v4 work folders and checkpoints were written, with the value they had before
    # they existed: left out of `as_dict` at that value, and read back as it where a settings dict lacks them, so
    # those folders' settings and checkpoints' configs still match the configuration they were made with
    LATER_FIELDS = {"history": 1, "augment_copies": 0, "augment_shift": 8}

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["cameras"] = list(self.cameras)
        for key, default in self.LATER_FIELDS.items():
            if d[key] == default:
                del d[key]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "LadderFlowConfig":
        d = {**cls.LATER_FIELDS, **d}
        d["cameras"] = tuple(d["cameras"])
        return cls(**d)


class ActionNormalizer:
    """Per-dimension affine map of actions to about [-1, 1] (min/max over the demos, constant dims kept)."""

    def __init__(self, low: torch.Tensor, high: torch.Tensor):
        self.low, self.high = low.float(), high.float()
        self.scale = ((self.high - self.low) / 2).clamp(min=1e-6)
        self.centre = (self.high + self.low) / 2

    @classmethod
    def fit(cls, actions: torch.Tensor) -> "ActionNormalizer":
        flat = actions.reshape(-1, actions.shape[-1])
        return cls(flat.min(dim=0).values, flat.max(dim=0).values)

    def normalize(self, a: torch.Tensor) -> torch.Tensor:
        return (a - self.centre.to(a.device)) / self.scale.to(a.device)

    def denormalize(self, a: torch.Tensor) -> torch.Tensor:
        return a * self.scale.to(a.device) + self.centre.to(a.device)

    def state_dict(self) -> dict:
        return {"low": self.low, "high": self.high}


def _time_embedding(t: torch.Tensor, dim: int) -> torch.Tensor:
    """Sinusoidal embedding of flow times t in [0, 1], (B,) -> (B, dim)."""
    half = dim // 2
    freqs = torch.exp(-math.log(1000.0) * torch.arange(half, device=t.device) / half)
    angles = t[:, None] * 1000.0 * freqs[None]
    return torch.cat([angles.sin(), angles.cos()], dim=1)


class SpatialSoftmaxPool(nn.Module):
    """A camera's (side x side) token map -> `k` tokens: each keypoint is a learned softmax over the cells
    (per camera), giving the expected cell position (x, y in [-1, 1]) and the softmax-weighted feature."""

    def __init__(self, cameras: int, cells: int, dim: int, k: int):
        super().__init__()
        side = int(round(math.sqrt(cells)))
        if side * side != cells:
            raise ValueError(f"spatial softmax needs a square token map per camera, got {cells} tokens")
        self.cameras, self.cells, self.k = cameras, cells, k
        self.norm = nn.LayerNorm(dim)
        self.logits = nn.Parameter(torch.randn(cameras, dim, k) * dim ** -0.5)
        ys, xs = torch.meshgrid(torch.linspace(-1, 1, side), torch.linspace(-1, 1, side), indexing="ij")
        self.register_buffer("xy", torch.stack([xs.flatten(), ys.flatten()], dim=1), persistent=False)  # (cells, 2)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """(B, cameras * cells, dim) -> (B, cameras * k, dim + 2)."""
        b = features.shape[0]
        f = self.norm(features.reshape(b, self.cameras, self.cells, -1))
        w = torch.einsum("bcpd,cdk->bckp", f, self.logits).softmax(dim=-1)  # (B, cameras, k, cells)
        pooled = torch.cat([w @ f, w @ self.xy], dim=-1)  # (B, cameras, k, dim + 2)
        return pooled.reshape(b, self.cameras * self.k, -1)


class LadderFlowNet(nn.Module):
    """Transformer encoder over observation tokens; transformer decoder over the noisy chunk."""

    def __init__(self, config: LadderFlowConfig, feature_dim: int, action_dim: int, n_tokens: Optional[int] = None):
        super().__init__()
        c = config
        self.config, self.action_dim = c, action_dim
        n_tokens = n_tokens or len(c.cameras) * c.grid * c.grid  # encoder tokens of all cameras, one frame
        self.n_tokens = n_tokens
        self.pool = None
        if c.keypoints:  # one pool per camera, shared by the history's frames
            self.pool = SpatialSoftmaxPool(len(c.cameras), n_tokens // len(c.cameras), feature_dim, c.keypoints)
            n_obs, feature_dim = len(c.cameras) * c.keypoints * c.history, feature_dim + 2
        else:
            n_obs = n_tokens * c.history
        self.obs_proj = nn.Sequential(nn.LayerNorm(feature_dim), nn.Linear(feature_dim, c.d_model))
        self.obs_pos = nn.Parameter(torch.randn(1, n_obs, c.d_model) * 0.02)
        self.action_in = nn.Linear(action_dim, c.d_model)
        self.action_pos = nn.Parameter(torch.randn(1, c.chunk, c.d_model) * 0.02)
        self.time_mlp = nn.Sequential(nn.Linear(c.d_model, c.d_model), nn.SiLU(), nn.Linear(c.d_model, c.d_model))
        layer = dict(d_model=c.d_model, nhead=c.heads, dim_feedforward=4 * c.d_model, dropout=c.dropout,
                     batch_first=True, norm_first=True)
        self.encoder = nn.TransformerEncoder(nn.TransformerEncoderLayer(**layer), c.encoder_layers)
        self.decoder = nn.TransformerDecoder(nn.TransformerDecoderLayer(**layer), c.decoder_layers)
        self.head = nn.Sequential(nn.LayerNorm(c.d_model), nn.Linear(c.d_model, action_dim))

    def encode_obs(self, features: torch.Tensor) -> torch.Tensor:
        """(B, history * cameras * tokens, feature_dim), the current frame first -> memory (B, n_obs, d_model)."""
        if self.pool is not None:
            b, h = features.shape[0], self.config.history
            features = self.pool(features.reshape(b * h, self.n_tokens, -1)).reshape(b, -1, features.shape[-1] + 2)
        return self.encoder(self.obs_proj(features) + self.obs_pos)

    def velocity(self, memory: torch.Tensor, x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """Predicted flow velocity (B, chunk, A) at noisy chunk x_t and time t (B,)."""
        time = self.time_mlp(_time_embedding(t, self.config.d_model))[:, None]
        h = self.action_in(x_t) + self.action_pos + time
        return self.head(self.decoder(h, memory + time))

    def loss(self, features: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Flow-matching loss of normalised action chunks (B, chunk, A) given obs features."""
        b = actions.shape[0]
        t = torch.rand(b, device=actions.device)
        x0 = torch.randn_like(actions)
        x_t = (1 - t[:, None, None]) * x0 + t[:, None, None] * actions
        return ((self.velocity(self.encode_obs(features), x_t, t) - (actions - x0)) ** 2).mean()

    @torch.no_grad()
    def sample(self, features: torch.Tensor, generator: Optional[torch.Generator] = None,
               noise: float = 1.0) -> torch.Tensor:
        """Normalised action chunks (B, chunk, A) by Euler integration from `noise` x N(0, I) (1: the protocol;
        0: from the chunk space's centre, deterministic - an ablation, `scripts/state_oracle.py --noise`)."""
        b, steps = features.shape[0], self.config.integration_steps
        memory = self.encode_obs(features)
        x = noise * torch.randn(b, self.config.chunk, self.action_dim, generator=generator, device=features.device)
        for k in range(steps):
            t = torch.full((b,), k / steps, device=features.device)
            x = x + self.velocity(memory, x, t) / steps
        return x


def chunk_targets(actions: torch.Tensor, chunk: int) -> torch.Tensor:
    """(T, A) actions of one episode -> (T, chunk, A): from each step the next `chunk` actions, the last
    one repeated past the episode's end (the demo holds its final command)."""
    T = actions.shape[0]
    idx = torch.arange(T)[:, None] + torch.arange(chunk)[None]
    return actions[idx.clamp(max=T - 1)]


def with_history(features: torch.Tensor, frames: torch.Tensor, history: int, every: int) -> torch.Tensor:
    """(F, tokens, D) features of one episode's steps `frames` -> (F, history * tokens, D): each frame followed by
    the frames `every`, 2 `every`, ... steps before it (the latest cached frame at or before that step; the first
    frame before the episode's start), as the policy sees them when it observes every `every` steps."""
    if history == 1:
        return features
    frames = torch.as_tensor(frames).long()
    stacked = [features]
    for j in range(1, history):
        idx = torch.searchsorted(frames, frames - j * every, right=True) - 1
        stacked.append(features[idx.clamp(min=0)])
    return torch.cat(stacked, dim=1)


class LadderFlowTrainer:
    """Train one policy on one task's demos: `episodes` is a list of (features (F, n_obs, D), actions (T, A)[,
    frames (F,)]): the features of the steps `frames` (default: every step) and all of the episode's actions;
    each feature frame's target is the chunk of actions from its step on."""

    def __init__(self, config: LadderFlowConfig, episodes: list, device: str = "cpu"):
        if not episodes:
            raise ValueError("no demonstration episodes to train on")
        torch.manual_seed(config.seed)
        self.config, self.device = config, device
        actions = [torch.as_tensor(ep[1]).float() for ep in episodes]
        frames = [torch.as_tensor(ep[2]).long() if len(ep) > 2 else torch.arange(len(ep[1])) for ep in episodes]
        n_tokens = episodes[0][0].shape[1]
        feats = torch.cat([with_history(ep[0].float(), f, config.history, config.execute)
                           for ep, f in zip(episodes, frames)])
        # augmented copies (copies, N, tokens, dim) of every frame (`features.cache_features`), if any
        copies = [ep[3] for ep in episodes if len(ep) > 3]
        if config.augment_copies and len(copies) != len(episodes):
            raise ValueError(f"augment_copies={config.augment_copies} but the features hold no augmented copies")
        self.augmented = None
        if config.augment_copies:
            self.augmented = torch.cat([torch.stack([with_history(c.float(), f, config.history, config.execute) for c in cs])
                                        for cs, f in zip(copies, frames)], dim=1).to(device)
        self.normalizer = ActionNormalizer.fit(torch.cat(actions))
        targets = torch.cat([chunk_targets(self.normalizer.normalize(a), config.chunk)[f] for a, f in zip(actions, frames)])
        if feats.shape[0] != targets.shape[0]:
            raise ValueError(f"{feats.shape[0]} feature frames but {targets.shape[0]} action steps")
        self.features, self.targets = feats.to(device), targets.to(device)
        self.net = LadderFlowNet(config, feats.shape[-1], targets.shape[-1], n_tokens=n_tokens).to(device)
        self.ema = copy.deepcopy(self.net).eval()
        for p in self.ema.parameters():
            p.requires_grad_(False)
        self.opt = torch.optim.AdamW(self.net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
        self.sched = torch.optim.lr_scheduler.CosineAnnealingLR(self.opt, T_max=max(config.train_steps, 1))
        self.step_count = 0

    def train(self, steps: int, progress: bool = False) -> list[float]:
        """`steps` optimiser steps on random minibatches; returns the loss of each."""
        from tqdm import tqdm

        losses = []
        n = self.features.shape[0]
        self.net.train()
        for _ in tqdm(range(steps), desc="train", disable=not progress):
            idx = torch.randint(0, n, (min(self.config.batch_size, n),), device=self.device)
            features = self.features[idx]
            if self.augmented is not None:  # each sample: the frame itself or one of its shifted copies
                copy = torch.randint(0, self.augmented.shape[0] + 1, idx.shape, device=self.device)
                shifted = copy > 0
                features[shifted] = self.augmented[copy[shifted] - 1, idx[shifted]]
            loss = self.net.loss(features, self.targets[idx])
            self.opt.zero_grad(set_to_none=True)
            loss.backward()
            nn.utils.clip_grad_norm_(self.net.parameters(), 1.0)
            self.opt.step()
            self.sched.step()
            with torch.no_grad():
                for pe, p in zip(self.ema.parameters(), self.net.parameters()):
                    pe.lerp_(p, 1 - self.config.ema_decay)
            self.step_count += 1
            losses.append(loss.item())
        return losses

    def policy(self) -> "LadderFlowPolicy":
        return LadderFlowPolicy(self.config, copy.deepcopy(self.ema).cpu(), self.normalizer)

    def save(self, path, meta: Optional[dict] = None) -> Path:
        """A checkpoint (written whole or not at all); `meta`: what the policy acts in (task, control_mode, ...).
        It holds the optimiser too, so `resume` continues training from it."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".partial")
        torch.save({
            "protocol": PROTOCOL_VERSION, "config": self.config.as_dict(), "step": self.step_count, "meta": meta or {},
            "feature_dim": self.features.shape[-1], "action_dim": self.targets.shape[-1], "n_tokens": self.net.n_tokens,
            "normalizer": self.normalizer.state_dict(), "net": self.net.state_dict(), "ema": self.ema.state_dict(),
            "optimizer": self.opt.state_dict(), "scheduler": self.sched.state_dict(),
            "rng": torch.get_rng_state(),
            "cuda_rng": torch.cuda.get_rng_state_all() if str(self.device).startswith("cuda") else None,
        }, tmp)
        tmp.replace(path)
        return path

    def resume(self, path) -> int:
        """Continue from a checkpoint `save` wrote with the same config and demos; returns its step."""
        ckpt = torch.load(Path(path), map_location=self.device, weights_only=False)
        if ckpt["config"] != self.config.as_dict():
            raise ValueError(f"{path} was trained with another configuration")
        self.net.load_state_dict(ckpt["net"])
        self.ema.load_state_dict(ckpt["ema"])
        self.opt.load_state_dict(ckpt["optimizer"])
        self.sched.load_state_dict(ckpt["scheduler"])
        self.step_count = int(ckpt["step"])
        # the RNG where the saved run was: the minibatches, flow times and noise after a resume are the ones an
        # uninterrupted run draws, so both end in the same weights
        torch.set_rng_state(ckpt["rng"].cpu())
        if ckpt.get("cuda_rng") is not None and str(self.device).startswith("cuda"):
            torch.cuda.set_rng_state_all(ckpt["cuda_rng"])
        return self.step_count


class LadderFlowPolicy:
    """A trained policy: obs features (n_obs, D) -> an action chunk (execute, A) in the env's units."""

    def __init__(self, config: LadderFlowConfig, net: LadderFlowNet, normalizer: ActionNormalizer,
                 meta: Optional[dict] = None):
        self.config, self.net, self.normalizer = config, net.eval(), normalizer
        self.meta = meta or {}

    @classmethod
    def load(cls, path) -> "LadderFlowPolicy":
        ckpt = torch.load(Path(path), map_location="cpu", weights_only=False)
        if ckpt.get("protocol") != PROTOCOL_VERSION:
            raise ValueError(f"{path}: a protocol {ckpt.get('protocol')!r} checkpoint; this code runs {PROTOCOL_VERSION}")
        config = LadderFlowConfig.from_dict(ckpt["config"])
        net = LadderFlowNet(config, ckpt["feature_dim"], ckpt["action_dim"], n_tokens=ckpt.get("n_tokens"))
        net.load_state_dict(ckpt["ema"])
        return cls(config, net, ActionNormalizer(**ckpt["normalizer"]), ckpt.get("meta"))

    @torch.no_grad()
    def act(self, features: torch.Tensor, generator: Optional[torch.Generator] = None, noise: float = 1.0) -> torch.Tensor:
        chunk = self.net.sample(features.float()[None], generator=generator, noise=noise)[0]
        return self.normalizer.denormalize(chunk)[: self.config.execute]
