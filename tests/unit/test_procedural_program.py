"""The procedural texture family's rows (tracer/shader/procedural_textures.py): SPECS is well
formed, the settings ints round-trip, and each opcode run by `execute` on a register file gives
what its formula function gives for the same inputs, every input in its own slot (the formulas
themselves are held against Cycles in tests/blender/test_procedural_textures.py).

Every register holds a distinct value, so a row that reads one input from another's slot (for
instance roughness and lacunarity swapped in NOISE) changes the result and is caught: measured
by swapping them in execute, test_noise_row failed (Fac 0.6558 against 0.6292)."""
from __future__ import annotations

import numpy as np
import pytest

from snell.tracer.shader import gabor, noise, patterns, voronoi
from snell.tracer.shader import procedural_textures as pt

VEC, Q1, Q2, Q3, OUT, OUT2, C1, C2, C3 = 0, 3, 6, 9, 12, 15, 18, 21, 24
FLOATS = 27


def _regs(**values):
    """A register file whose inputs are distinct values: VEC a point, Q1-Q3 parameter blocks,
    C1-C3 colours; outputs NaN until written."""
    regs = np.full(40, np.nan)
    regs[VEC:VEC + 3] = (0.37, -0.81, 0.23)
    regs[C1:C1 + 3] = (0.9, 0.5, 0.1)
    regs[C2:C2 + 3] = (0.2, 0.3, 0.7)
    regs[C3:C3 + 3] = (0.05, 0.04, 0.03)
    for name, v in values.items():
        r = globals()[name]
        regs[r:r + len(v)] = v
    return regs


def _run(row, regs):
    ins = np.zeros(8, dtype=np.int64)
    ins[:len(row)] = row
    pt.execute(ins, regs, np.zeros(1))
    return regs


def test_specs_are_well_formed():
    """Every opcode is in the family's range 300-399 with a description, 7 slot letters and
    bounds only on literal slots."""
    for code, spec in pt.SPECS.items():
        what, slots = spec[:2]
        assert 300 <= code <= 399
        assert ":" in what
        assert len(slots) == 7 and set(slots) <= set("fvid-"), (code, slots)
        for slot, limit in (spec[2] if len(spec) > 2 else {}).items():
            assert slots[slot - 1] == "i" and limit > 0, (code, slot)
    assert len(set(pt.SPECS)) == len(pt.SPECS)


def test_settings_round_trip():
    """settings packs decimal digits, setting reads them back; a digit above 9 is refused."""
    s = pt.settings(3, 1, 0, 1)
    assert s == 3101
    assert [pt.setting(s, i, 4) for i in range(4)] == [3, 1, 0, 1]
    with pytest.raises(ValueError):
        pt.settings(3, 10)


def test_component_row():
    """COMPONENT copies one register of a block into a float register."""
    regs = _run([pt.COMPONENT, C2, FLOATS, 2], _regs())
    assert regs[FLOATS] == 0.7


def test_params_row():
    """PARAMS gathers three float registers into a block."""
    regs = _run([pt.PARAMS, OUT, VEC + 2, C1, C2 + 1], _regs())
    assert tuple(regs[OUT:OUT + 3]) == (0.23, 0.9, 0.3)


def test_noise_row():
    """NOISE reads W, scale, detail / roughness, lacunarity, distortion / offset, gain from its
    blocks and writes noise_texture's colour."""
    regs = _regs(Q1=(0.4, 3.0, 2.5), Q2=(0.6, 2.2, 0.3), Q3=(0.7, 1.3, 0.0))
    for dims, kind, normalize in ((3, noise.FBM, 1), (4, noise.HYBRID_MULTIFRACTAL, 0),
                                  (1, noise.RIDGED_MULTIFRACTAL, 0)):
        _run([pt.NOISE, VEC, Q1, Q2, Q3, OUT, pt.settings(dims, kind, normalize), 1], regs)
        expect = noise.noise_texture(dims, 0.37, -0.81, 0.23, 0.4, 3.0, 2.5, 0.6, 2.2, 0.7, 1.3,
                                     0.3, kind, bool(normalize), True)[1]
        assert tuple(regs[OUT:OUT + 3]) == expect


def test_voronoi_rows():
    """VORONOI writes (Distance, W, Radius) and Color, VORONOI_POSITION Position and W, from
    voronoi_texture with W, scale, detail / roughness, lacunarity, smoothness / exponent,
    randomness."""
    regs = _regs(Q1=(0.4, 3.0, 1.5), Q2=(0.6, 2.2, 0.8), Q3=(1.7, 0.9, 0.0))
    for dims, feature, metric, normalize in ((3, voronoi.F1, voronoi.MINKOWSKI, 1),
                                             (4, voronoi.SMOOTH_F1, voronoi.EUCLIDEAN, 0),
                                             (2, voronoi.F2, voronoi.CHEBYCHEV, 1)):
        s = pt.settings(dims, feature, metric, normalize)
        _run([pt.VORONOI, VEC, Q1, Q2, Q3, OUT, OUT2, s], regs)
        _run([pt.VORONOI_POSITION, VEC, Q1, Q2, Q3, C3, FLOATS, s], regs)
        d, color, position, w, radius = voronoi.voronoi_texture(
            dims, feature, metric, 0.37, -0.81, 0.23, 0.4, 3.0, 1.5, 0.6, 2.2, 0.8, 1.7, 0.9,
            bool(normalize))
        assert tuple(regs[OUT:OUT + 3]) == (d, w, radius)
        assert tuple(regs[OUT2:OUT2 + 3]) == color
        assert tuple(regs[C3:C3 + 3]) == position and regs[FLOATS] == w


def test_checker_row():
    """CHECKER picks color1 or color2 by svm_checker of the scaled point."""
    regs = _regs(Q1=(2.7, 0.0, 0.0))
    _run([pt.CHECKER, VEC, C1, C2, Q1, OUT, FLOATS], regs)
    f = patterns.checker(0.37 * 2.7, -0.81 * 2.7, 0.23 * 2.7)
    assert regs[FLOATS] == f
    assert tuple(regs[OUT:OUT + 3]) == tuple(regs[C1:C1 + 3] if f == 1.0 else regs[C2:C2 + 3])


def test_brick_rows():
    """BRICK gives (tint, mortar) of svm_brick; BRICK_COLOR mixes the colours as Cycles."""
    regs = _regs(Q1=(2.5, 0.1, 1.0), Q2=(0.2, 0.7, 0.3), Q3=(0.3, 0.6, 0.0))
    _run([pt.BRICK, VEC, Q1, Q2, Q3, OUT, 3, 2], regs)
    tint, mortar = patterns.brick(0.37 * 2.5, -0.81 * 2.5, 0.1, 1.0, 0.2, 0.7, 0.3, 0.3, 3, 0.6,
                                  2)
    assert tuple(regs[OUT:OUT + 2]) == (tint, mortar)
    assert 0.0 < mortar < 1.0
    _run([pt.BRICK_COLOR, OUT, C1, C2, C3, OUT2], regs)
    c1 = [(1 - tint) * a + tint * b for a, b in zip((0.9, 0.5, 0.1), (0.2, 0.3, 0.7))]
    expect = [a * (1 - mortar) + m * mortar for a, m in zip(c1, (0.05, 0.04, 0.03))]
    assert np.allclose(regs[OUT2:OUT2 + 3], expect, rtol=0, atol=1e-15)


def test_gradient_wave_magic_white_noise_rows():
    """GRADIENT, GREY, WAVE, MAGIC and WHITE_NOISE give their formulas' values."""
    regs = _regs(Q1=(1.5, 2.0, 3.5), Q2=(1.2, 0.7, 0.4))
    _run([pt.GRADIENT, VEC, FLOATS, patterns.RADIAL], regs)
    assert regs[FLOATS] == patterns.gradient(patterns.RADIAL, 0.37, -0.81, 0.23)
    _run([pt.GREY, FLOATS, OUT], regs)
    assert tuple(regs[OUT:OUT + 3]) == (regs[FLOATS],) * 3
    _run([pt.WAVE, VEC, Q1, Q2, FLOATS, patterns.RINGS, patterns.DIRECTION_Y, patterns.SAW],
         regs)
    assert regs[FLOATS] == patterns.wave(patterns.RINGS, patterns.DIRECTION_Y, patterns.SAW,
                                         0.37 * 1.5, -0.81 * 1.5, 0.23 * 1.5, 2.0, 3.5, 1.2, 0.7,
                                         0.4)
    _run([pt.MAGIC, VEC, Q1, Q1 + 1, OUT, FLOATS, 4], regs)
    color = patterns.magic(0.37, -0.81, 0.23, 1.5, 4, 2.0)
    assert tuple(regs[OUT:OUT + 3]) == color and regs[FLOATS] == sum(color) / 3.0
    _run([pt.WHITE_NOISE, VEC, Q2, FLOATS, OUT, 4], regs)
    value, color = patterns.white_noise(4, 0.37, -0.81, 0.23, 1.2)
    assert regs[FLOATS] == value and tuple(regs[OUT:OUT + 3]) == color


def test_wave_detail_is_bounded():
    """A Wave's Detail linked to a huge value (Cycles runs one octave per unit) takes 64 octaves
    at most: 1e9 returns at once, equal to 64 (without the bound 1e7 octaves took 1.4 s, so 1e9
    would take about 140 s)."""
    import time
    args = (patterns.BANDS, patterns.DIRECTION_X, patterns.SIN, 0.3, 0.2, 0.1, 2.0)
    patterns.wave(*args, 2.0, 1.0, 0.5, 0.0)
    start = time.perf_counter()
    value = patterns.wave(*args, 1e9, 1.0, 0.5, 0.0)
    assert time.perf_counter() - start < 0.5
    assert value == patterns.wave(*args, 64.0, 1.0, 0.5, 0.0)


def test_gabor_row():
    """GABOR writes gabor_texture's (Value, Phase, Intensity) from [scale, frequency,
    anisotropy], the 2D orientation and the 3D one."""
    regs = _regs(Q1=(3.0, 1.7, 0.4), Q2=(0.9, 0.0, 0.0), Q3=(0.2, -0.5, 0.8))
    for kind in (gabor.TYPE_2D, gabor.TYPE_3D):
        _run([pt.GABOR, VEC, Q1, Q2, Q3, OUT, kind], regs)
        assert tuple(regs[OUT:OUT + 3]) == gabor.gabor_texture(kind, 0.37, -0.81, 0.23, 3.0, 1.7,
                                                               0.4, 0.9, 0.2, -0.5, 0.8)
