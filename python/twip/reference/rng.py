"""The same random numbers as twip-core's rng: numpy's Philox4x64-10 words with Box–Muller
normals (a sweep's draws), and numpy's SFC64 words (the sensors' noise, through the
ziggurat in `twip.reference.realism`)."""
from __future__ import annotations

import math

import numpy as np


class _Words:
    """A stream of 64-bit words (`next_u64`) and what the core makes of them."""

    def next_u64(self) -> int:
        return int(self._bits.random_raw())

    def uniform(self) -> float:
        return (self.next_u64() >> 11) * (1.0 / (1 << 53))


class Philox(_Words):
    """Stream `stream` of seed `seed`: numpy's Philox with key = [seed, stream]."""

    def __init__(self, seed: int, stream: int):
        self._bits = np.random.Philox(key=[seed, stream], counter=[0, 0, 0, 0])
        self._spare = None

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


class Sfc64(_Words):
    """Stream `stream` of seed `seed` as the core's `Sfc64::new`: numpy's SFC64 started from
    the first three words of Philox stream (seed, stream), then numpy's own seeding (counter
    1, twelve outputs discarded)."""

    WARM_UP = 12

    def __init__(self, seed: int, stream: int):
        a, b, c = np.random.Philox(key=[seed, stream], counter=[0, 0, 0, 0]).random_raw(3)
        self._bits = np.random.SFC64()
        self._bits.state = {
            "bit_generator": "SFC64",
            "state": {"state": np.array([a, b, c, 1], dtype=np.uint64)},
            "has_uint32": 0,
            "uinteger": 0,
        }
        self._bits.random_raw(self.WARM_UP)
