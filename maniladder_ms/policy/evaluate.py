"""A trained LadderFlow checkpoint as a `maniladder eval` policy: it declares its cameras (only those are
rendered, and only when it is asked for actions), sees RGB alone, and returns action chunks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from .encoders import make_encoder
from .features import encode_frames
from .flow import LadderFlowPolicy


class LadderFlowEvalPolicy:
    """`policy(obs, spec) -> (execute, A)` for one task's checkpoint (`meta`: task, control_mode)."""

    obs_mode = "rgb"

    def __init__(self, checkpoint, encoder=None, seed: int = 0):
        self.policy = LadderFlowPolicy.load(Path(checkpoint))
        config = self.policy.config
        self.cameras = tuple(config.cameras)
        self.image_size = config.image_size  # the eval env renders what the policy was trained on
        self.control_mode = self.policy.meta.get("control_mode")
        self.task = self.policy.meta.get("task")
        self.encoder = encoder or make_encoder(config.encoder, grid=config.grid)
        self.generator = torch.Generator().manual_seed(seed)
        self.past = []

    def supports(self, spec):
        return True if self.task in (None, spec.id) else f"checkpoint trained on {self.task}"

    def reset(self, ctx):
        self.generator.manual_seed(int(ctx.seed))  # the flow's noise: reproducible per episode
        self.past = []  # features of the frames observed before, the latest first (`LadderFlowConfig.history`)

    def __call__(self, obs, spec):
        images = np.stack([obs["sensor_data"][cam]["rgb"][0].cpu().numpy() for cam in self.cameras])[None]
        features = encode_frames(self.encoder, images)[0]
        history = self.policy.config.history
        if history > 1:  # as training stacks them (`flow.with_history`): before the first frame, the first frame
            frames = [features] + self.past[: history - 1]
            frames += [frames[-1]] * (history - len(frames))
            self.past = frames[: history - 1]
            features = torch.cat(frames, dim=0)
        return self.policy.act(features, generator=self.generator).numpy()
