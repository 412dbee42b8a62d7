"""The same noise as twip-core's rng.rs: Philox4x64-10 words from numpy, Box–Muller normals."""
from __future__ import annotations

import math

import numpy as np


class Philox:
    """Stream `stream` of seed `seed`: numpy's Philox with key = [seed, stream]."""

    def __init__(self, seed: int, stream: int):
        self._bits = np.random.Philox(key=[seed, stream], counter=[0, 0, 0, 0])
        self._spare = None

    def next_u64(self) -> int:
        return int(self._bits.random_raw())

    def uniform(self) -> float:
        return (self.next_u64() >> 11) * (1.0 / (1 << 53))

    def normal(self) -> float:
        if self._spare is not None:
            z, self._spare = self._spare, None
            return z
        u1 = 1.0 - self.uniform()
        u2 = self.uniform()
        radius = math.sqrt(-2.0 * math.log(u1))
        angle = 2.0 * math.pi * u2
        self._spare = radius * math.sin(angle)
        return radius * math.cos(angle)
