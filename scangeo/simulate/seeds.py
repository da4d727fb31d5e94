"""The random generators of a simulated block: one per purpose, seeded by the block's seed.

Every random draw of a simulation comes from the generator named after its purpose ("terrain",
"errors 02", "measurements", ...), so a seed gives the same block whatever else is switched on or
off (images, blunders, a second sensor).
"""
from __future__ import annotations

import zlib

import numpy as np


def rng_for(seed: int, purpose: str) -> np.random.Generator:
    """A generator for one purpose ("terrain", "errors 02", ...) of a seeded block."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, zlib.crc32(purpose.encode())])


__all__ = ["rng_for"]
