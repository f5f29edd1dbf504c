"""Cycles' bounce limits of each kind and sample clamping, as scalar functions
(tracer/path_limits.py; rendered against Cycles in tests/validation/test_light_paths_compare.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from snell.tracer import path_limits as pl
from snell.tracer.lights.codes import VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION


def test_clamp_scales_the_sum_of_absolute_values_to_the_limit():
    value = (10.0, 0.0, -5.0)
    clamped = pl.clamp_light(value, 3.0)
    assert sum(abs(c) for c in clamped) == pytest.approx(3.0)
    np.testing.assert_allclose(clamped, (2.0, 0.0, -1.0))     # the colour's ratios kept


def test_values_within_the_limit_are_unchanged():
    assert pl.clamp_light((1.0, 0.5, 1.5), 3.0) == (1.0, 0.5, 1.5)
    assert pl.clamp_light((1e30, 1e30, 1e30), pl.NO_CLAMP) == (1e30, 1e30, 1e30)


def test_cycles_settings_become_limits_on_the_sum():
    """Cycles' scene/integrator.cpp: sample_clamp * 3, and 0 is no clamp (FLT_MAX)."""
    assert pl.clamp_limits(0.0, 10.0) == (math.inf, 30.0)
    assert pl.clamp_limit(pl.clamp_limits(1.0, 2.0), True) == 3.0
    assert pl.clamp_limit(pl.clamp_limits(1.0, 2.0), False) == 6.0


def test_events_count_by_kind_as_cycles_labels():
    assert pl.bounce_kind(VISIBLE_DIFFUSE, False) == pl.DIFFUSE_BOUNCE
    assert pl.bounce_kind(VISIBLE_GLOSSY, False) == pl.GLOSSY_BOUNCE
    # Translucency is diffuse but a transmission (LABEL_TRANSMIT | LABEL_DIFFUSE).
    assert pl.bounce_kind(VISIBLE_DIFFUSE, True) == pl.TRANSMISSION_BOUNCE
    # A refraction is one whatever the geometric normal says (shading normals can bend it).
    assert pl.bounce_kind(VISIBLE_TRANSMISSION, True) == pl.TRANSMISSION_BOUNCE
    assert pl.bounce_kind(VISIBLE_TRANSMISSION, False) == pl.TRANSMISSION_BOUNCE
    assert pl.bounce_kind(VISIBLE_GLOSSY, True) == pl.GLOSSY_BOUNCE


@pytest.mark.parametrize("bounce, kinds, past", [
    (3, (2, 1, 0), False),      # every count at its limit: one more scattering is allowed
    (3, (3, 0, 0), True),       # diffuse past 2
    (3, (0, 3, 0), True),       # glossy past 2
    (3, (0, 0, 4), True),       # transmission past 3
    (8, (0, 0, 0), True),       # the total: max depth 8
    (7, (2, 2, 3), False),
])
def test_a_path_scatters_no_more_past_any_limit(bounce, kinds, past):
    limits = pl.bounce_limits(8, 8, 2, 2, 3)
    assert pl.past_last_bounce(bounce, pl.packed(*kinds), limits) is past
    if bounce < 8:
        assert pl.within_limits(pl.packed(*kinds), limits) is not past


@pytest.mark.parametrize("kinds", [(0, 0, 0), (1, 0, 0), (0, 7, 0), (1024, 3, 2048), (5, 0, 9)])
def test_packed_counts_read_back_and_count_up_one_kind_at_a_time(kinds):
    counts = pl.packed(*kinds)
    assert [pl.kind_count(counts, k) for k in range(3)] == list(kinds)
    for k in range(3):
        more = pl.add_bounce(counts, k)
        assert [pl.kind_count(more, j) for j in range(3)] == [
            c + (j == k) for j, c in enumerate(kinds)]
