"""The address-keyed random choice of stochastic productions (model.md section 1).

u = the first 8 bytes, big-endian, of SHA-256 of the UTF-8 text
``f"{seed}:{address}"``, divided by 2**64; of alternatives with probabilities
p_1..p_m (file order) the first whose cumulative sum exceeds u * sum(p) is
taken, the last one if rounding leaves none. The choice depends on nothing but
the seed and the address, so every derivation agrees on its first k steps.
"""

from __future__ import annotations

import hashlib

import numpy as np

_TWO_64 = float(2 ** 64)


def address_fraction(seed: int, address: str) -> float:
    """u in [0, 1) for one module address such as ``"0.3.1"``."""
    digest = hashlib.sha256(f"{int(seed)}:{address}".encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") / _TWO_64


def address_fractions(seed: int, addresses: list[str]) -> np.ndarray:
    """(len(addresses),) float64: `address_fraction` of each address."""
    out = np.empty(len(addresses), dtype=np.float64)
    prefix = f"{int(seed)}:"
    sha = hashlib.sha256
    for i, address in enumerate(addresses):
        digest = sha((prefix + address).encode("utf-8")).digest()
        out[i] = int.from_bytes(digest[:8], "big") / _TWO_64
    return out


def choose(probabilities: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Pick one alternative per module.

    probabilities : (m, k) float64, alternative weights in file order, one row per module
    u             : (m,) float64 in [0, 1)
    returns (m,) int64 alternative index in 0..k-1
    """
    cumulative = np.cumsum(probabilities, axis=1)          # sequential sums, file order
    threshold = u * cumulative[:, -1]
    exceeds = cumulative > threshold[:, None]
    first = np.argmax(exceeds, axis=1)
    return np.where(exceeds.any(axis=1), first, probabilities.shape[1] - 1).astype(np.int64)
