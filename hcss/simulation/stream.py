"""The compiled kernels' random stream: xoshiro256** with its state in a numpy array.

The kernels (movement, rules, messages) draw from this stream instead of the
trial's `numpy.random.Generator`: handing a Generator to a compiled function
costs tens of microseconds per call, more than the whole step should. The
stream's state is four uint64 words stored in the World (`World.stream`), so
snapshots, restores and state digests carry it like any other state array.
It is seeded from the same SeedSequence as the trial's Generator (scenario
seed, run number), on its own spawn key, so the two streams are independent.

xoshiro256** (Blackman & Vigna 2018): 256-bit state, period 2^256 - 1,
passes BigCrush; doubles take the top 53 bits. Normal deviates come from the
256-layer ziggurat (Marsaglia & Tsang 2000, numpy's variant): one 64-bit draw
for 99 % of them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hcss.simulation.jit import internal

_U64 = np.uint64
_TO_UNIT = 1.0 / 9007199254740992.0  # 2^-53


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 256-layer ziggurat of the standard normal: layer bounds, widths and heights.

    Marsaglia & Tsang's construction with numpy's 52-bit layout: the base
    strip (layer 0, with the tail beyond r) and 255 rectangles of equal area v.
    """
    r = _ZIGGURAT_R

    def density(x: float) -> float:
        return math.exp(-0.5 * x * x)

    v = r * density(r) + math.sqrt(math.pi / 2.0) * math.erfc(r / math.sqrt(2.0))
    m = 2.0**52
    ki = np.zeros(256, dtype=np.uint64)
    wi = np.zeros(256)
    fi = np.zeros(256)
    q = v / density(r)
    ki[0], wi[0], fi[0] = int(r / q * m), q / m, 1.0
    wi[255], fi[255] = r / m, density(r)
    x = upper = r
    for i in range(254, 0, -1):
        x = math.sqrt(-2.0 * math.log(v / x + density(x)))
        ki[i + 1] = int(x / upper * m)
        upper = x
        fi[i] = density(x)
        wi[i] = x / m
    return ki, wi, fi


_ZIGGURAT_R = 3.6541528853610088  # where the base strip's tail begins
_ZIG_K, _ZIG_W, _ZIG_F = _ziggurat_tables()


#: A stream state held in registers: the four 64-bit words of xoshiro256**.
Words = tuple[np.uint64, np.uint64, np.uint64, np.uint64]


def seed_stream(seed: int, run: int) -> np.ndarray:
    """A fresh stream state for a trial's (scenario seed, run)."""
    state = np.random.SeedSequence(seed, spawn_key=(2, run)).generate_state(4, np.uint64)
    if not state.any():  # the one forbidden state; practically unreachable
        state[0] = 1
    return state


@njit(cache=True, inline="always")
def _rotl(x: np.uint64, k: int) -> np.uint64:
    return (x << _U64(k)) | (x >> _U64(64 - k))


@njit(cache=True)
def _advance(
    s0: np.uint64, s1: np.uint64, s2: np.uint64, s3: np.uint64
) -> tuple[np.uint64, np.uint64, np.uint64, np.uint64, np.uint64]:
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


# A hot loop keeps the state in registers: `r = load(s)`, then `u, r = unit(r)` for
# each draw, then `store(s, r)`. The functions on `s` itself advance the array in place.
@njit(cache=True, inline="always")
def load(s: np.ndarray) -> Words:
    """The state as a tuple of four words, for a loop that draws many numbers."""
    return (s[0], s[1], s[2], s[3])


@njit(cache=True, inline="always")
def store(s: np.ndarray, r: Words) -> None:
    s[0], s[1], s[2], s[3] = r[0], r[1], r[2], r[3]


@njit(cache=True, inline="always")
def unit(r: Words) -> tuple[float, Words]:
    """(a double uniform in [0, 1), the advanced state)."""
    result, s0, s1, s2, s3 = _advance(r[0], r[1], r[2], r[3])
    return float(np.int64(result >> _U64(11))) * _TO_UNIT, (s0, s1, s2, s3)  # via int64: cheaper


@njit(cache=True, inline="always")
def index_below(r: Words, n: int) -> tuple[int, Words]:
    """(an integer uniform in [0, n), the advanced state); n > 0, the bias of 53-bit
    scaling is < 2^-40 here."""
    u, r = unit(r)
    return int(u * n), r


@njit(cache=True, inline="always")
def poisson_count(r: Words, limit: float) -> tuple[int, Words]:
    """(a Poisson count of mean λ given limit = exp(-λ), the advanced state): Knuth's product."""
    total = 0
    product, r = unit(r)
    while product > limit:
        total += 1
        u, r = unit(r)
        product *= u
    return total, r


@njit(cache=True, inline="always")
def poisson_count_of(r: Words, lam: float) -> tuple[int, Words]:
    """(a Poisson count of mean λ, the advanced state), in chunks of mean <= 20 so that
    exp(-λ) cannot underflow."""
    total = 0
    while lam > 0.0:
        chunk = min(lam, 20.0)
        lam -= chunk
        count, r = poisson_count(r, math.exp(-chunk))
        total += count
    return total, r


@njit(cache=True, inline="always")
def uniform(s: np.ndarray) -> float:
    """A double uniform in [0, 1); advances `s` in place."""
    u, r = unit(load(s))
    store(s, r)
    return u


@njit(cache=True, inline="always")
def below(s: np.ndarray, n: int) -> int:
    """An integer uniform in [0, n) (n > 0); advances `s` in place."""
    j, r = index_below(load(s), n)
    store(s, r)
    return j


@njit(cache=True)
def fill_normals(s: np.ndarray, out: np.ndarray) -> None:
    """Standard normal deviates into `out` (ziggurat), the state kept in registers meanwhile.

    Each deviate takes a layer, a sign and a point from one 64-bit draw; the
    rare draws outside the layer's rectangle go to `_normal_edge`. A caller
    that needs one deviate per agent draws them all first, in this tight loop.
    """
    s0, s1, s2, s3 = s[0], s[1], s[2], s[3]
    i = 0
    while i < out.size:
        bits, s0, s1, s2, s3 = _advance(s0, s1, s2, s3)
        layer = bits & _U64(0xFF)
        bits >>= _U64(8)
        negative = bits & _U64(1)
        magnitude = (bits >> _U64(1)) & _U64(0x000FFFFFFFFFFFFF)
        x = float(np.int64(magnitude)) * _ZIG_W[layer]
        if magnitude >= _ZIG_K[layer]:  # outside the layer's rectangle: 1 % of draws
            s[0], s[1], s[2], s[3] = s0, s1, s2, s3
            x = _normal_edge(s, layer, x)
            s0, s1, s2, s3 = s[0], s[1], s[2], s[3]
            if x != x:  # rejected: draw again
                continue
        out[i] = -x if negative else x
        i += 1
    s[0], s[1], s[2], s[3] = s0, s1, s2, s3


@internal
def _normal_edge(s: np.ndarray, layer: np.uint64, x: float) -> float:
    """The rare draws outside a layer's rectangle: |deviate| from the tail (layer 0) or
    the wedge, NaN if the wedge rejects it (draw again)."""
    if layer == 0:
        while True:
            xx = -math.log1p(-uniform(s)) / _ZIGGURAT_R
            yy = -math.log1p(-uniform(s))
            if yy + yy > xx * xx:
                return _ZIGGURAT_R + xx
    if (_ZIG_F[layer - 1] - _ZIG_F[layer]) * uniform(s) + _ZIG_F[layer] < math.exp(-0.5 * x * x):
        return x
    return math.nan
