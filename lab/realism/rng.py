"""A counter-based normal generator, written out identically in cpp/realism/rng.hpp.

Draw k of a stream is a pure function of (seed, k): SplitMix64 (Steele, Lea and Flood 2014,
the seeding generator of xoshiro) on the state seed + (k + 1)·γ, two such words make one
Box–Muller normal. Both kernels draw the same numbers for the same seed and counter (the
agreement test compares them to 1e-12), and a tick may skip draws it does not need without
moving the others: noise i of tick t is always draw t·width + i.
"""

import numpy as np

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_TO_UNIT = 2.0**-53  # 53 random bits -> [0, 1)


def splitmix64(state: np.ndarray) -> np.ndarray:
    """SplitMix64's output function on each uint64 of `state` (wrapping arithmetic)."""
    z = state.astype(np.uint64)
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


def uniforms(seed: int, first: int, count: int) -> np.ndarray:
    """Draws first .. first + count − 1 of stream `seed` as doubles in [0, 1)."""
    k = np.arange(first + 1, first + count + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        words = splitmix64(np.uint64(seed & 0xFFFFFFFFFFFFFFFF) + k * GOLDEN)
    return (words >> np.uint64(11)).astype(np.float64) * _TO_UNIT


def normals(seed: int, first: int, count: int) -> np.ndarray:
    """Standard normals first .. first + count − 1 of stream `seed`: normal i from uniforms
    2i and 2i + 1 (Box–Muller's cosine branch; 1 − u keeps the logarithm finite)."""
    u = uniforms(seed, 2 * first, 2 * count)
    return np.sqrt(-2.0 * np.log(1.0 - u[0::2])) * np.cos(2.0 * np.pi * u[1::2])
