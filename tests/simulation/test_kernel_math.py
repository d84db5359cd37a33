"""The faster kernels' arithmetic: ziggurat normals, vectorised rotations, the cheap leave test.

Each replaces a library call on the hot path; these tests hold it to the
library's answer (rotations, leave test) or to the distribution it must draw
from (normals), with a fixed stream so that they cannot flake.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from hcss.simulation.movement import fill_cos_sin
from hcss.simulation.rules import per_step_probability, within_step
from hcss.simulation.stream import fill_normals, seed_stream


def test_ziggurat_normals_are_standard_normal_in_the_body_and_the_tail():
    draws = np.empty(400_000)
    fill_normals(seed_stream(11, 0), draws)
    assert abs(draws.mean()) < 0.005 and abs(draws.std() - 1.0) < 0.005
    assert stats.kstest(draws, "norm").pvalue > 0.01
    tail = np.abs(draws[np.abs(draws) > 3.0])  # the base strip's tail starts at 3.65
    assert tail.size == pytest.approx(400_000 * 2 * stats.norm.sf(3.0), rel=0.1)
    assert stats.kstest(tail, lambda x: 1 - stats.norm.sf(x) / stats.norm.sf(3.0)).pvalue > 0.01


def test_the_stream_continues_across_calls_as_in_one():
    whole, parts = np.empty(1000), np.empty(1000)
    fill_normals(seed_stream(3, 1), whole)
    state = seed_stream(3, 1)
    fill_normals(state, parts[:377])
    fill_normals(state, parts[377:])
    np.testing.assert_array_equal(whole, parts)


def test_vectorised_rotations_match_libm_within_an_ulp():
    rng = np.random.default_rng(5)
    angles = np.concatenate(
        (
            rng.normal(0.0, 0.5, 5000),  # the walkers' turns
            rng.uniform(-50.0, 50.0, 5000),
            [0.0, -0.0, math.pi / 4, math.pi / 2, -math.pi, 3 * math.pi / 2, 1e7, -3e9],
        )
    )
    cos_out, sin_out = np.empty_like(angles), np.empty_like(angles)
    fill_cos_sin(angles, cos_out, sin_out)
    expected_cos = np.array([math.cos(a) for a in angles])
    expected_sin = np.array([math.sin(a) for a in angles])
    assert np.max(np.abs(cos_out - expected_cos)) <= 2.3e-16
    assert np.max(np.abs(sin_out - expected_sin)) <= 2.3e-16


@pytest.mark.parametrize("rate", [1e-9, 0.004, 0.3, 0.999, 1.0, 2.5, 40.0])
def test_the_cheap_leave_test_decides_as_the_exact_probability(rate):
    p = per_step_probability(rate, 1.0)
    draws = np.concatenate(
        (np.linspace(0.0, 1.0, 2001), [p, np.nextafter(p, 0), rate * (1 - rate)])
    )
    for u in draws:
        assert within_step(float(u), rate, 1.0) == (u < p), (u, rate)
