"""Procedural textures for domain randomisation: table tops and backdrops.

Generated once from fixed seeds with numpy and cached as PNGs, so every machine gets the same set.
"""

from pathlib import Path

import numpy as np

from maniladder_ms.paths import cache_dir

TEXTURE_SIZE = 256
TEXTURE_KINDS = ("wood", "checker", "marble", "fabric")
VARIANTS_PER_KIND = 3


def _smooth_noise(rng: np.random.Generator, size: int, cells: int) -> np.ndarray:
    """Value noise in [0, 1]: a coarse random grid upsampled bilinearly (tileable enough for a table)."""
    grid = rng.random((cells + 1, cells + 1))
    t = np.linspace(0, cells, size, endpoint=False)
    i = t.astype(int)
    f = t - i
    f = f * f * (3 - 2 * f)
    top = grid[i][:, i] * (1 - f)[None, :] + grid[i][:, i + 1] * f[None, :]
    bottom = grid[i + 1][:, i] * (1 - f)[None, :] + grid[i + 1][:, i + 1] * f[None, :]
    return top * (1 - f)[:, None] + bottom * f[:, None]


def _fractal_noise(rng, size):
    return sum(_smooth_noise(rng, size, 2**k) / 2**k for k in range(2, 6)) / sum(1 / 2**k for k in range(2, 6))


def _two_tone(mask: np.ndarray, a, b) -> np.ndarray:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return mask[..., None] * a + (1 - mask[..., None]) * b


def make_texture(kind: str, seed: int, size: int = TEXTURE_SIZE) -> np.ndarray:
    """An RGB uint8 image of the given kind; the same (kind, seed) always gives the same image."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(0.25, 0.85, 3)
    other = np.clip(base * rng.uniform(0.4, 0.8) + rng.uniform(-0.1, 0.1, 3), 0, 1)
    y, x = np.mgrid[0:size, 0:size] / size
    if kind == "wood":
        base, other = np.array([0.55, 0.36, 0.2]) * rng.uniform(0.8, 1.2), np.array([0.35, 0.2, 0.1])
        rings = np.sin(2 * np.pi * (rng.uniform(8, 16) * y + 3 * _fractal_noise(rng, size)))
        img = _two_tone(0.5 + 0.5 * rings, base, other)
    elif kind == "checker":
        n = rng.integers(4, 10)
        img = _two_tone(((np.floor(x * n) + np.floor(y * n)) % 2).astype(float), base, other)
    elif kind == "marble":
        veins = np.abs(np.sin(2 * np.pi * (x + y + 2 * _fractal_noise(rng, size))))
        img = _two_tone(veins**0.5, base, other)
    elif kind == "fabric":
        n = rng.integers(20, 40)
        weave = 0.5 + 0.25 * np.sin(2 * np.pi * n * x) + 0.25 * np.sin(2 * np.pi * n * y)
        img = _two_tone(weave, base, other)
    else:
        raise ValueError(f"unknown texture kind {kind!r}; known: {', '.join(TEXTURE_KINDS)}")
    img = img * (0.9 + 0.2 * _fractal_noise(rng, size))[..., None]
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def texture_files() -> list[Path]:
    """Paths of the whole procedural texture set, generating missing ones."""
    from PIL import Image

    out = []
    folder = cache_dir("textures")
    for k, kind in enumerate(TEXTURE_KINDS):
        for v in range(VARIANTS_PER_KIND):
            path = folder / f"{kind}_{v}.png"
            if not path.exists():
                tmp = path.with_suffix(".tmp.png")
                Image.fromarray(make_texture(kind, seed=1000 * k + v)).save(tmp)
                tmp.replace(path)
            out.append(path)
    return out
