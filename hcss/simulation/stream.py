"""The compiled kernels' random stream: xoshiro256** with its state in a numpy array.

The kernels (movement, rules, messages) draw from this stream instead of the
trial's `numpy.random.Generator`: handing a Generator to a compiled function
costs tens of microseconds per call, more than the whole step should. The
stream's state is four uint64 words stored in the World (`World.stream`), so
snapshots, restores and state digests carry it like any other state array.
It is seeded from the same SeedSequence as the trial's Generator (scenario
seed, run number), on its own spawn key, so the two streams are independent.

xoshiro256** (Blackman & Vigna 2018): 256-bit state, period 2^256 - 1,
passes BigCrush; doubles take the top 53 bits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_U64 = np.uint64
_TO_UNIT = 1.0 / 9007199254740992.0  # 2^-53


def seed_stream(seed: int, run: int) -> np.ndarray:
    """A fresh stream state for a trial's (scenario seed, run)."""
    state = np.random.SeedSequence(seed, spawn_key=(2, run)).generate_state(4, np.uint64)
    if not state.any():  # the one forbidden state; practically unreachable
        state[0] = 1
    return state


@njit(cache=True, inline="always")
def _rotl(x, k):
    return (x << _U64(k)) | (x >> _U64(64 - k))


@njit(cache=True)
def _advance(s0, s1, s2, s3):
    """One xoshiro256** step on a state held in registers: (64 random bits, new state)."""
    result = _rotl(s1 * _U64(5), 7) * _U64(9)
    t = s1 << _U64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, 45)
    return result, s0, s1, s2, s3


@njit(cache=True, inline="always")
def next_u64(s):
    """The next 64 random bits; advances the state in place."""
    result, s[0], s[1], s[2], s[3] = _advance(s[0], s[1], s[2], s[3])
    return result


@njit(cache=True, inline="always")
def uniform(s):
    """A double uniform in [0, 1)."""
    return float(next_u64(s) >> _U64(11)) * _TO_UNIT


@njit(cache=True, inline="always")
def below(s, n):
    """An integer uniform in [0, n) (n > 0); the bias of 53-bit scaling is < 2^-40 here."""
    return int(uniform(s) * n)


@njit(cache=True)
def fill_normals(s, out):
    """Standard normal deviates into `out`, the state kept in registers meanwhile.

    Marsaglia's polar method, both deviates of each pair used, in a tight
    loop: a caller that needs one deviate per agent draws them all first,
    which is much faster than interleaving the draws with its other work.
    """
    s0, s1, s2, s3 = s[0], s[1], s[2], s[3]
    i = 0
    while i < out.size:
        a, s0, s1, s2, s3 = _advance(s0, s1, s2, s3)
        b, s0, s1, s2, s3 = _advance(s0, s1, s2, s3)
        u = 2.0 * (float(a >> _U64(11)) * _TO_UNIT) - 1.0
        v = 2.0 * (float(b >> _U64(11)) * _TO_UNIT) - 1.0
        r2 = u * u + v * v
        if not 0.0 < r2 < 1.0:
            continue
        factor = math.sqrt(-2.0 * math.log(r2) / r2)
        out[i] = u * factor
        if i + 1 < out.size:
            out[i + 1] = v * factor
        i += 2
    s[0], s[1], s[2], s[3] = s0, s1, s2, s3


@njit(cache=True, inline="always")
def poisson_below(s, limit):
    """A Poisson count of mean λ given limit = exp(-λ), by multiplication (Knuth)."""
    total = 0
    product = uniform(s)
    while product > limit:
        total += 1
        product *= uniform(s)
    return total


@njit(cache=True, inline="always")
def poisson(s, lam):
    """A Poisson count, in chunks of mean <= 20 so that exp(-λ) cannot underflow."""
    total = 0
    while lam > 0.0:
        chunk = min(lam, 20.0)
        lam -= chunk
        total += poisson_below(s, math.exp(-chunk))
    return total
