"""The procedural textures' formulas (tracer/shader/noise.py, voronoi.py, patterns.py, hashes.py)
held against Cycles point by point: each node drives the emission of the probe plane
(support/node_probe.py) and the jitted function is evaluated where Cycles' sample 0 landed.

Where that is: a first probe renders the coordinates themselves (the plane's Object coordinates
turned and moved by a Mapping node, so that z varies too), so each pixel holds the float32 point
Cycles shaded (sample 0 lands 6.6e-5 off the pixel's centre on this 16 px probe, the same in
every render). 1D and 4D nodes take W from the point's x. Evaluating there, Snell and Cycles
differ by float32 rounding only (Cycles computes in float32, Snell in float64), measured: at most
1.8e-4 for Noise (which adds offsets of 100-200 to the coordinates, where float32's spacing is
1.5e-5), 3.8e-5 for Magic, 1.1e-5 for Brick, 2.7e-6 for Wave, 8.5e-7 for Gabor, 5.1e-7 for
Voronoi, 8.6e-8 for Gradient and 0 for White Noise and Checker. Each family's tolerance is a few
times its measured difference. Pixels within 2e-4 of a discontinuity (a cell's or a brick's edge)
are left out explicitly: Snell's value there changes within that distance of the point; each test
bounds how many it leaves out.

Each node's Cycles images are rendered once per module (about 1 s each; the module runs in
about 20 s). Each test shows its teeth on its own images: the same comparison with a scale off by
1% (10% for Checker and Brick, whose values are piecewise constant) must fail by more than ten
times the tolerance. Errors put into the code on purpose, one at a time, were caught (measured):
- lookup3's seed 0xdeadbeef + 14 instead of + 13 (hashes.py): 26 tests fail (every Noise case,
  1D Voronoi, White Noise, the hash values, Wave with distortion);
- PCG 2D's increment 1013904224 instead of 1013904223: the six 2D Voronoi cases fail;
- noise_scale3 0.980 instead of 0.982: the five 3D Noise cases and Wave with distortion fail;
- grad3's z negated (a z term, invisible on the plane z = 0 without the Mapping node): the same
  seven fail;
- brick_noise's 60494 instead of 60493: the Brick Color case fails;
- Smooth F1's colour correction 1 + 3.05 s instead of 1 + 3 s: the 1D, 3D and 4D Smooth F1 cases
  fail;
- Wave's diagonal bands at 10.05 instead of 10: the diagonal Wave case fails;
- Gabor's 2D kernel centres hashed with seed 3k + 2 instead of 3k + 1: the three 2D cases fail;
- Gabor's 3D random orientation with sine and cosine of the azimuth swapped: the 3D case with
  some isotropy fails (the fully anisotropic one keeps the base orientation, as in Cycles).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.node_probe import probe  # noqa: E402

from snell.tracer.shader import gabor, hashes, noise, patterns, voronoi  # noqa: E402

SIZE = 16
EXTENT = 1.0
# float32 rounding, by family (measured differences in the module's docstring)
TOL_NOISE = 5e-4
TOL_SMOOTH = 1e-4
TOL_EXACT = 1e-5
# how far a discontinuity may be from the shaded point and still move it
EDGE = 2e-4


def _socket(sockets, identifier):
    # by identifier: disabled sockets (Vector of a 1D node) are not found by name
    return next(s for s in sockets if s.identifier == identifier)


# The plane's Object coordinates turned and moved by a Mapping node, so that the textures see
# points whose z varies too (on the plane alone z = 0, where a 3D formula's z terms vanish)
LOCATION = (0.3, -0.2, 0.4)
ROTATION = (0.5, 0.7, 0.2)


def _coordinates(tree):
    """The mapped Object coordinates' socket."""
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "POINT"
    mapping.inputs["Location"].default_value = LOCATION
    mapping.inputs["Rotation"].default_value = ROTATION
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Object"],
                   mapping.inputs["Vector"])
    return mapping.outputs["Vector"]


def _graph(idname, props, inputs, output, w_from_x=False, snap=None):
    """build(tree) for the probe: a node of type idname fed with the mapped coordinates (its W
    from their x when w_from_x; snapped to a grid of `snap` first if given)."""
    def build(tree):
        coords = _coordinates(tree)
        if snap is not None:
            snapper = tree.nodes.new("ShaderNodeVectorMath")
            snapper.operation = "SNAP"
            tree.links.new(coords, snapper.inputs[0])
            snapper.inputs[1].default_value = (snap, snap, snap)
            coords = snapper.outputs[0]
        node = tree.nodes.new(idname)
        for name, value in props.items():
            setattr(node, name, value)
        for name, value in inputs.items():
            _socket(node.inputs, name).default_value = value
        if w_from_x:
            sep = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(coords, sep.inputs[0])
            tree.links.new(sep.outputs["X"], _socket(node.inputs, "W"))
        if _socket(node.inputs, "Vector").enabled:
            tree.links.new(coords, _socket(node.inputs, "Vector"))
        return _socket(node.outputs, output)
    return build


def _render(build):
    image, _ = probe(build, size=SIZE, extent=EXTENT)
    return image


@pytest.fixture(scope="module")
def points():
    """(SIZE, SIZE, 3): the float32 points Cycles shades (the mapped coordinates), read back
    from the probe."""
    pts = _render(_coordinates)
    assert np.ptp(pts[..., 2]) > 1.0
    return pts


def _evaluate(fn, pts):
    """fn(x, y, z) -> float or 3-tuple at every point, as a (SIZE, SIZE, 3) image (a float is
    splatted, as a Fac linked into a colour is)."""
    out = np.zeros(pts.shape[:2] + (3,))
    for r in range(pts.shape[0]):
        for c in range(pts.shape[1]):
            v = fn(*(float(t) for t in pts[r, c]))
            out[r, c] = v
    return out


def _near_edges(fn, pts):
    """Pixels whose value changes within EDGE of the point (a discontinuity there)."""
    base = _evaluate(fn, pts)
    near = np.zeros(pts.shape[:2], dtype=bool)
    for axis in range(3):
        for sign in (-1.0, 1.0):
            moved = pts.copy()
            moved[..., axis] += sign * EDGE
            jump = np.abs(_evaluate(fn, moved) - base).max(axis=2)
            near |= jump > 0.05
    return near


def _error(image, fn, pts, exclude=None):
    """Largest |Cycles - fn| over the pixels not excluded."""
    err = np.abs(image - _evaluate(fn, pts)).max(axis=2)
    if exclude is not None:
        err = err[~exclude]
    return float(err.max())


def _check(image, fn, pts, wrong, tol, discontinuous=False, max_excluded=0.2):
    """fn agrees with Cycles' image within tol (away from its discontinuities when it has
    them), and the deliberately wrong variant is off by more than 10 tol; returns (error,
    wrong error)."""
    exclude = _near_edges(fn, pts) if discontinuous else None
    if exclude is not None:
        assert exclude.mean() <= max_excluded, exclude.mean()
    err = _error(image, fn, pts, exclude)
    bad = _error(image, wrong, pts, exclude)
    assert err < tol, (err, bad)
    assert bad > 10 * tol, (err, bad)
    return err, bad


# ---- Noise -----------------------------------------------------------------------------------

NOISE_TYPES = {"MULTIFRACTAL": noise.MULTIFRACTAL, "FBM": noise.FBM,
               "HYBRID_MULTIFRACTAL": noise.HYBRID_MULTIFRACTAL,
               "RIDGED_MULTIFRACTAL": noise.RIDGED_MULTIFRACTAL,
               "HETERO_TERRAIN": noise.HETERO_TERRAIN}
NOISE_CASES = [
    # (dimensions, type, normalize, inputs)
    ("1D", "FBM", True, dict(Scale=3.0, Detail=2.5, Roughness=0.6, Distortion=0.3)),
    ("2D", "FBM", True, dict(Scale=3.0, Detail=2.5, Roughness=0.6, Distortion=0.3)),
    ("3D", "FBM", True, dict(Scale=2.0, Detail=1.0, Roughness=0.5, Distortion=0.0)),
    ("3D", "FBM", False, dict(Scale=4.0, Detail=3.7, Roughness=0.45, Lacunarity=2.5,
                              Distortion=1.5)),
    ("4D", "FBM", True, dict(Scale=3.0, Detail=2.5, Roughness=0.6, Distortion=0.3)),
    ("3D", "MULTIFRACTAL", False, dict(Scale=3.0, Detail=2.5, Roughness=0.6)),
    ("2D", "HYBRID_MULTIFRACTAL", False, dict(Scale=3.0, Detail=2.5, Roughness=0.6, Offset=0.8,
                                              Gain=1.5)),
    ("3D", "RIDGED_MULTIFRACTAL", False, dict(Scale=3.0, Detail=3.0, Roughness=0.6, Offset=1.0,
                                              Gain=2.0)),
    ("4D", "HETERO_TERRAIN", False, dict(Scale=3.0, Detail=2.5, Roughness=0.6, Offset=0.2,
                                         Distortion=0.4)),
    ("1D", "MULTIFRACTAL", False, dict(Scale=4.0, Detail=4.3, Roughness=0.7)),
    ("2D", "RIDGED_MULTIFRACTAL", False, dict(Scale=2.0, Detail=2.0, Offset=0.9, Gain=1.7)),
    ("4D", "RIDGED_MULTIFRACTAL", False, dict(Scale=2.0, Detail=1.5, Offset=1.1, Gain=2.2)),
    ("3D", "HETERO_TERRAIN", False, dict(Scale=2.5, Detail=0.0, Offset=0.5)),
    ("3D", "FBM", True, dict(Scale=2.5, Detail=3.0, Roughness=0.0)),
]
_NOISE_DEFAULTS = dict(W=0.0, Scale=5.0, Detail=2.0, Roughness=0.5, Lacunarity=2.0, Offset=0.0,
                       Gain=1.0, Distortion=0.0)


def _noise_fn(dims, kind, normalize, inputs, scale_factor=1.0):
    d = int(dims[0])
    a = dict(_NOISE_DEFAULTS, **inputs)

    def fn(x, y, z):
        w = x if d in (1, 4) else a["W"]
        return noise.noise_texture(d, x, y, z, w, a["Scale"] * scale_factor, a["Detail"],
                                   a["Roughness"], a["Lacunarity"], a["Offset"], a["Gain"],
                                   a["Distortion"], NOISE_TYPES[kind], normalize, True)[1]
    return fn


@pytest.fixture(scope="module")
def noise_images():
    return [_render(_graph("ShaderNodeTexNoise",
                           dict(noise_dimensions=dims, noise_type=kind, normalize=normalize),
                           inputs, "Color", w_from_x=dims in ("1D", "4D")))
            for dims, kind, normalize, inputs in NOISE_CASES]


@pytest.mark.parametrize("case", range(len(NOISE_CASES)))
def test_noise_matches_cycles(noise_images, points, case):
    """Noise Texture's Color (its Fac is the red channel) in 1D-4D, each fractal type,
    normalized or not, with distortion, agrees with Cycles to float32 rounding (largest
    difference 1.8e-4, unnormalized fBm with distortion 1.5); its Scale off by 1% is caught in
    every case (by 0.025-0.69)."""
    dims, kind, normalize, inputs = NOISE_CASES[case]
    _check(noise_images[case], _noise_fn(dims, kind, normalize, inputs), points,
           _noise_fn(dims, kind, normalize, inputs, scale_factor=1.01), TOL_NOISE)


# ---- Voronoi ---------------------------------------------------------------------------------

FEATURES = {"F1": voronoi.F1, "F2": voronoi.F2, "SMOOTH_F1": voronoi.SMOOTH_F1,
            "DISTANCE_TO_EDGE": voronoi.DISTANCE_TO_EDGE,
            "N_SPHERE_RADIUS": voronoi.N_SPHERE_RADIUS}
METRICS = {"EUCLIDEAN": voronoi.EUCLIDEAN, "MANHATTAN": voronoi.MANHATTAN,
           "CHEBYCHEV": voronoi.CHEBYCHEV, "MINKOWSKI": voronoi.MINKOWSKI}
VORONOI_CASES = [
    # (dimensions, feature, metric, normalize, output, inputs)
    ("1D", "F1", "EUCLIDEAN", False, "Distance", dict(Scale=3.0)),
    ("1D", "F2", "EUCLIDEAN", True, "Color", dict(Scale=3.0, Detail=1.5)),
    ("1D", "SMOOTH_F1", "EUCLIDEAN", False, "W", dict(Scale=3.0, Smoothness=0.7)),
    ("1D", "DISTANCE_TO_EDGE", "EUCLIDEAN", False, "Distance", dict(Scale=3.0, Randomness=0.8)),
    ("1D", "N_SPHERE_RADIUS", "EUCLIDEAN", False, "Radius", dict(Scale=3.0)),
    ("2D", "F1", "EUCLIDEAN", False, "Color", dict(Scale=3.0)),
    ("2D", "F1", "MANHATTAN", True, "Distance", dict(Scale=3.0, Detail=2.5, Roughness=0.6)),
    ("2D", "F2", "CHEBYCHEV", False, "Position", dict(Scale=3.0, Randomness=0.7)),
    ("2D", "SMOOTH_F1", "MINKOWSKI", False, "Distance", dict(Scale=3.0, Exponent=1.5,
                                                             Smoothness=0.5)),
    ("2D", "DISTANCE_TO_EDGE", "EUCLIDEAN", True, "Distance", dict(Scale=3.0, Detail=1.5)),
    ("2D", "N_SPHERE_RADIUS", "EUCLIDEAN", False, "Radius", dict(Scale=3.0)),
    ("3D", "F1", "EUCLIDEAN", False, "Distance", dict(Scale=4.0, Detail=2.0, Roughness=0.5)),
    ("3D", "F1", "MINKOWSKI", False, "Color", dict(Scale=3.0, Exponent=0.8)),
    ("3D", "F2", "EUCLIDEAN", True, "Distance", dict(Scale=3.0)),
    ("3D", "SMOOTH_F1", "EUCLIDEAN", False, "Color", dict(Scale=3.0, Smoothness=1.0)),
    ("3D", "DISTANCE_TO_EDGE", "EUCLIDEAN", False, "Distance", dict(Scale=3.0)),
    ("3D", "N_SPHERE_RADIUS", "EUCLIDEAN", False, "Radius", dict(Scale=3.0)),
    ("4D", "F1", "EUCLIDEAN", False, "Color", dict(Scale=3.0)),
    ("4D", "F2", "MANHATTAN", False, "Distance", dict(Scale=3.0)),
    ("4D", "SMOOTH_F1", "EUCLIDEAN", False, "Position", dict(Scale=2.0, Smoothness=0.4)),
    ("4D", "DISTANCE_TO_EDGE", "EUCLIDEAN", False, "Distance", dict(Scale=3.0)),
    ("4D", "N_SPHERE_RADIUS", "EUCLIDEAN", False, "Radius", dict(Scale=3.0)),
    ("1D", "F1", "EUCLIDEAN", True, "Color", dict(Scale=2.0, Detail=2.5, Roughness=0.7,
                                                  Lacunarity=2.5)),
    ("3D", "F1", "CHEBYCHEV", False, "Distance", dict(Scale=3.0, Randomness=0.6)),
    ("4D", "F1", "MINKOWSKI", True, "Distance", dict(Scale=2.0, Exponent=2.5, Detail=1.3)),
    ("3D", "DISTANCE_TO_EDGE", "EUCLIDEAN", True, "Distance", dict(Scale=2.0, Detail=2.7,
                                                                   Roughness=0.6)),
    ("4D", "F2", "EUCLIDEAN", False, "W", dict(Scale=2.0)),
    # no randomness: the points sit on the cells' corners (a regular grid)
    ("2D", "F2", "EUCLIDEAN", False, "Color", dict(Scale=3.0, Randomness=0.0)),
    ("3D", "F1", "MANHATTAN", False, "Color", dict(Scale=3.0, Randomness=0.0)),
    ("3D", "F1", "EUCLIDEAN", True, "Distance", dict(Scale=3.0, Detail=2.0, Roughness=0.0)),
]
_VORONOI_DEFAULTS = dict(W=0.0, Scale=5.0, Detail=0.0, Roughness=0.5, Lacunarity=2.0,
                         Smoothness=1.0, Exponent=0.5, Randomness=1.0)
_OUTPUTS = ("Distance", "Color", "Position", "W", "Radius")


def _voronoi_fn(dims, feature, metric, normalize, output, inputs, scale_factor=1.0):
    d = int(dims[0])
    a = dict(_VORONOI_DEFAULTS, **inputs)
    which = _OUTPUTS.index(output)

    def fn(x, y, z):
        w = x if d in (1, 4) else a["W"]
        return voronoi.voronoi_texture(d, FEATURES[feature], METRICS[metric], x, y, z, w,
                                       a["Scale"] * scale_factor, a["Detail"], a["Roughness"],
                                       a["Lacunarity"], a["Smoothness"], a["Exponent"],
                                       a["Randomness"], normalize)[which]
    return fn


@pytest.fixture(scope="module")
def voronoi_images():
    return [_render(_graph("ShaderNodeTexVoronoi",
                           dict(voronoi_dimensions=dims, feature=feature, distance=metric,
                                normalize=normalize),
                           inputs, output, w_from_x=dims in ("1D", "4D")))
            for dims, feature, metric, normalize, output, inputs in VORONOI_CASES]


@pytest.mark.parametrize("case", range(len(VORONOI_CASES)))
def test_voronoi_matches_cycles(voronoi_images, points, case):
    """Voronoi Texture, every feature in 1D-4D, the four metrics, fractal octaves, Normalize
    and each output, agrees with Cycles to float32 rounding away from cell edges (largest
    difference 5.1e-7, at most 1.6% of the pixels left out); its Scale off by 1% is caught in
    every case (by 0.011-0.89)."""
    dims, feature, metric, normalize, output, inputs = VORONOI_CASES[case]
    args = (dims, feature, metric, normalize, output, inputs)
    _check(voronoi_images[case], _voronoi_fn(*args), points,
           _voronoi_fn(*args, scale_factor=1.01), TOL_EXACT, discontinuous=True,
           max_excluded=0.25)


# ---- White Noise -----------------------------------------------------------------------------

WHITE_CASES = [("1D", "Color"), ("2D", "Value"), ("3D", "Color"), ("4D", "Color")]
SNAP = 0.25


@pytest.fixture(scope="module")
def white_images():
    return [_render(_graph("ShaderNodeTexWhiteNoise", dict(noise_dimensions=dims),
                           dict(W=0.3), output, w_from_x=dims in ("1D", "4D"), snap=SNAP))
            for dims, output in WHITE_CASES]


def _white_fn(dims, output, seed_shift=0.0):
    d = int(dims[0])

    def fn(x, y, z):
        # the graph snaps the coordinates to a grid (Vector Math Snap: floor(p / s) * s),
        # since the hash of a float changes with its last bit
        x, y, z = (float(np.floor(t / SNAP) * SNAP) for t in (x, y, z))
        w = x if d in (1, 4) else 0.3
        value, color = patterns.white_noise(d, x + seed_shift, y, z, w + seed_shift)
        return color if output == "Color" else value
    return fn


@pytest.mark.parametrize("case", range(len(WHITE_CASES)))
def test_white_noise_matches_cycles(white_images, points, case):
    """White Noise in 1D-4D (Jenkins lookup3 on the float32 bits) equals Cycles' to float32
    rounding on every cell of a snapped grid; hashing a coordinate one grid step off is
    caught."""
    dims, output = WHITE_CASES[case]
    _check(white_images[case], _white_fn(dims, output), points, _white_fn(dims, output, SNAP),
           TOL_EXACT, discontinuous=True)


def test_hashes_bit_exact():
    """The hashes on a few keys, as lookup3 and PCG define them (values computed with this
    module and held against Cycles through the White Noise and Voronoi probes above); the
    float hash reads the float32 bits (1.0 -> 0x3f800000)."""
    assert hashes.float_bits(1.0) == 0x3F800000
    assert hashes.float_bits(-0.0) == 0x80000000
    assert hashes.hash_uint(0) == 2501500005
    assert hashes.hash_uint2(1, 2) == 272092061
    assert hashes.hash_uint4(1, 2, 3, 4) == 92593857


# ---- Checker, Brick, Gradient, Wave, Magic ---------------------------------------------------

def _checker_fn(scale):
    def fn(x, y, z):
        return patterns.checker(x * scale, y * scale, z * scale)
    return fn


@pytest.mark.parametrize("scale", [3.0, 5.5])
def test_checker_matches_cycles(points, scale):
    """Checker's Fac equals Cycles' away from the squares' edges; a scale off by 10% is caught
    (1% and 5% move no square's edge across a pixel's point on this probe)."""
    image = _render(_graph("ShaderNodeTexChecker", {}, dict(Scale=scale), "Fac"))
    _check(image, _checker_fn(scale), points, _checker_fn(scale * 1.1), TOL_EXACT,
           discontinuous=True)


BRICK_CASES = [
    # (offset, offset_frequency, squash, squash_frequency, inputs, output)
    (0.5, 2, 1.0, 2, dict(Scale=3.0, Bias=0.0), "Fac"),
    (0.3, 3, 0.6, 2, dict(Scale=2.5, **{"Mortar Size": 0.05, "Mortar Smooth": 0.4,
                                        "Brick Width": 0.7, "Row Height": 0.3, "Bias": 0.2}),
     "Color"),
]


def _brick_fn(case, scale_factor=1.0):
    offset, offset_freq, squash, squash_freq, inputs, output = case
    a = dict({"Scale": 5.0, "Mortar Size": 0.02, "Mortar Smooth": 0.1, "Bias": 0.0,
              "Brick Width": 0.5, "Row Height": 0.25}, **inputs)
    c1, c2, mortar = (0.8, 0.8, 0.8), (0.2, 0.2, 0.2), (0.0, 0.0, 0.0)

    def fn(x, y, z):
        s = a["Scale"] * scale_factor
        tint, f = patterns.brick(x * s, y * s, a["Mortar Size"], a["Mortar Smooth"], a["Bias"],
                                 a["Brick Width"], a["Row Height"], offset, offset_freq,
                                 squash, squash_freq)
        if output == "Fac":
            return f
        col = [(1.0 - tint) * p + tint * q for p, q in zip(c1, c2)] if f != 1.0 else c1
        return tuple(p * (1.0 - f) + m * f for p, m in zip(col, mortar))
    return fn


@pytest.mark.parametrize("case", range(len(BRICK_CASES)))
def test_brick_matches_cycles(points, case):
    """Brick's Fac (mortar) and Color (tinted bricks by Cycles' integer noise), with offset
    and squash, equal Cycles' away from the bricks' edges; a scale off by 10% is caught (1% moves
    no mortar line across a pixel's point on this probe)."""
    offset, offset_freq, squash, squash_freq, inputs, output = BRICK_CASES[case]
    props = dict(offset=offset, offset_frequency=offset_freq, squash=squash,
                 squash_frequency=squash_freq)
    image = _render(_graph("ShaderNodeTexBrick", props, inputs, output))
    _check(image, _brick_fn(BRICK_CASES[case]), points,
           _brick_fn(BRICK_CASES[case], scale_factor=1.1), TOL_SMOOTH, discontinuous=True)


GRADIENTS = {"LINEAR": patterns.LINEAR, "QUADRATIC": patterns.QUADRATIC,
             "EASING": patterns.EASING, "DIAGONAL": patterns.DIAGONAL,
             "RADIAL": patterns.RADIAL, "QUADRATIC_SPHERE": patterns.QUADRATIC_SPHERE,
             "SPHERICAL": patterns.SPHERICAL}


@pytest.fixture(scope="module")
def gradient_images():
    return {kind: _render(_graph("ShaderNodeTexGradient", dict(gradient_type=kind), {}, "Fac"))
            for kind in GRADIENTS}


@pytest.mark.parametrize("kind", list(GRADIENTS))
def test_gradient_matches_cycles(gradient_images, points, kind):
    """Each Gradient type equals Cycles'; the point moved by 1% of its coordinates is
    caught."""
    def fn(x, y, z):
        return patterns.gradient(GRADIENTS[kind], x, y, z)

    def wrong(x, y, z):
        return patterns.gradient(GRADIENTS[kind], x * 1.01 + 0.01, y * 1.01 + 0.01, z)
    _check(gradient_images[kind], fn, points, wrong, TOL_EXACT,
           discontinuous=kind == "RADIAL")


WAVE_CASES = [
    # (type, direction, profile, inputs)
    ("BANDS", "X", "SIN", dict(Scale=2.0)),
    ("BANDS", "DIAGONAL", "SAW", dict(Scale=1.5, Distortion=2.0, Detail=3.5)),
    ("RINGS", "SPHERICAL", "TRI", dict(Scale=1.0, **{"Phase Offset": 0.7})),
    ("RINGS", "Z", "SIN", dict(Scale=1.3, Distortion=4.0, Detail=2.0,
                               **{"Detail Scale": 2.0, "Detail Roughness": 0.7})),
    ("BANDS", "Y", "TRI", dict(Scale=0.8)),
]
_WAVE_KIND = {"BANDS": patterns.BANDS, "RINGS": patterns.RINGS}
_WAVE_DIRECTION = {"X": patterns.DIRECTION_X, "Y": patterns.DIRECTION_Y,
                   "Z": patterns.DIRECTION_Z, "DIAGONAL": patterns.DIRECTION_DIAGONAL_OR_SPHERICAL,
                   "SPHERICAL": patterns.DIRECTION_DIAGONAL_OR_SPHERICAL}
_WAVE_PROFILE = {"SIN": patterns.SIN, "SAW": patterns.SAW, "TRI": patterns.TRI}


def _wave_fn(case, scale_factor=1.0):
    kind, direction, profile, inputs = case
    a = dict({"Scale": 5.0, "Distortion": 0.0, "Detail": 2.0, "Detail Scale": 1.0,
              "Detail Roughness": 0.5, "Phase Offset": 0.0}, **inputs)

    def fn(x, y, z):
        s = a["Scale"] * scale_factor
        return patterns.wave(_WAVE_KIND[kind], _WAVE_DIRECTION[direction], _WAVE_PROFILE[profile],
                             x * s, y * s, z * s, a["Distortion"], a["Detail"],
                             a["Detail Scale"], a["Detail Roughness"], a["Phase Offset"])
    return fn


@pytest.mark.parametrize("case", range(len(WAVE_CASES)))
def test_wave_matches_cycles(points, case):
    """Wave bands and rings, each profile, with distortion and detail, equal Cycles' (saw
    teeth left out); a scale off by 1% is caught."""
    kind, direction, profile, inputs = WAVE_CASES[case]
    props = dict(wave_type=kind, wave_profile=profile)
    props["bands_direction" if kind == "BANDS" else "rings_direction"] = direction
    image = _render(_graph("ShaderNodeTexWave", props, inputs, "Fac"))
    _check(image, _wave_fn(WAVE_CASES[case]), points, _wave_fn(WAVE_CASES[case], 1.01),
           TOL_SMOOTH, discontinuous=profile == "SAW")


MAGIC_CASES = [(2, dict(Scale=2.0, Distortion=1.0)), (5, dict(Scale=1.5, Distortion=2.5)),
               (0, dict(Scale=3.0, Distortion=0.0)), (10, dict(Scale=1.0, Distortion=1.3))]


@pytest.mark.parametrize("case", range(len(MAGIC_CASES)))
def test_magic_matches_cycles(points, case):
    """Magic's colour at depths 0-10 equals Cycles'; a scale off by 1% is caught."""
    depth, inputs = MAGIC_CASES[case]
    image = _render(_graph("ShaderNodeTexMagic", dict(turbulence_depth=depth), inputs, "Color"))

    def fn(x, y, z, f=1.0):
        return patterns.magic(x, y, z, inputs["Scale"] * f, depth, inputs["Distortion"])
    _check(image, fn, points, lambda x, y, z: fn(x, y, z, 1.01), TOL_SMOOTH)


GABOR_CASES = [
    # (type, output, inputs)
    ("2D", "Value", dict(Scale=3.0, Frequency=2.0, Anisotropy=1.0)),
    ("2D", "Phase", {"Scale": 2.0, "Frequency": 1.5, "Anisotropy": 0.3, "Orientation 2D": 0.4}),
    ("2D", "Intensity", dict(Scale=3.0, Frequency=3.0, Anisotropy=0.0)),
    ("3D", "Value", {"Scale": 2.0, "Frequency": 2.0, "Anisotropy": 1.0,
                     "Orientation 3D": (0.3, 0.5, 0.8)}),
    ("3D", "Intensity", {"Scale": 2.5, "Frequency": 1.2, "Anisotropy": 0.6,
                         "Orientation 3D": (-0.2, 0.9, 0.1)}),
]
_GABOR_DEFAULTS = {"Scale": 5.0, "Frequency": 2.0, "Anisotropy": 1.0,
                   "Orientation 2D": math.pi / 4, "Orientation 3D": (2 ** 0.5, 2 ** 0.5, 0.0)}


def _gabor_fn(case, scale_factor=1.0):
    kind, output, inputs = case
    a = dict(_GABOR_DEFAULTS, **inputs)
    which = ("Value", "Phase", "Intensity").index(output)

    def fn(x, y, z):
        return gabor.gabor_texture(gabor.TYPE_3D if kind == "3D" else gabor.TYPE_2D, x, y, z,
                                   a["Scale"] * scale_factor, a["Frequency"], a["Anisotropy"],
                                   a["Orientation 2D"], *a["Orientation 3D"])[which]
    return fn


@pytest.mark.parametrize("case", range(len(GABOR_CASES)))
def test_gabor_matches_cycles(points, case):
    """Gabor noise in 2D and 3D, isotropic to anisotropic, each output, equals Cycles' (largest
    difference 8.5e-7; the phase left out where it wraps); a scale off by 1% is caught (by
    0.06-0.99)."""
    kind, output, inputs = GABOR_CASES[case]
    image = _render(_graph("ShaderNodeTexGabor", dict(gabor_type=kind), inputs, output))
    _check(image, _gabor_fn(GABOR_CASES[case]), points, _gabor_fn(GABOR_CASES[case], 1.01),
           TOL_EXACT, discontinuous=output == "Phase")
