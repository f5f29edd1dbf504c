"""The surface evaluation that the light-sampling and light-vertex steps share
(tracer/direct_light.py): Lambert for diffuse vertices, the lobes for layered ones."""
import math

import numpy as np

from snell.tracer import lobes
from snell.tracer.direct_light import evaluate_surface, lit_events
from snell.tracer.lights.codes import VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY, \
    VISIBLE_TRANSMISSION
from snell.tracer.material_kinds import DIFFUSE, LAYERED

UP = (0.0, 0.0, 1.0)
ALBEDO = (0.8, 0.5, 0.2)
SCRATCH = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))


def _diffuse(w, ns=UP, ng=UP, shading_only=True):
    return evaluate_surface(DIFFUSE, ALBEDO, SCRATCH, 0, UP, ns, ng, w, 0, shading_only)


def test_diffuse_is_lambert_on_the_shading_normal():
    w = (0.6, 0.0, 0.8)
    color, scale, pdf, valid = _diffuse(w)
    assert valid and color == ALBEDO
    assert scale == 0.8 / math.pi and pdf == 0.8 / math.pi       # f |cos| = albedo cos / pi


def test_diffuse_below_the_shading_normal_gets_nothing():
    assert not _diffuse((0.6, 0.0, -0.8))[3]


def test_diffuse_below_the_geometric_surface_counts_only_for_light_samples():
    # Above the shading normal, below the geometric one: a light sample counts (its shadow ray
    # decides, as in Cycles), a connection to a light vertex does not.
    ns = (math.sin(0.3), 0.0, math.cos(0.3))
    w = (0.999, 0.0, -0.0447)
    w = tuple(np.array(w) / np.linalg.norm(w))
    assert _diffuse(w, ns=ns, shading_only=True)[3]
    assert not _diffuse(w, ns=ns, shading_only=False)[3]


def test_layered_is_the_lobes_evaluation_with_scale_one():
    # No lobes: nothing, and the density of sampling is the lobes' own (0).
    color, scale, pdf, valid = evaluate_surface(LAYERED, ALBEDO, SCRATCH, 0, UP, UP, UP,
                                                (0.0, 0.6, 0.8), lit_events(VISIBLE_DIFFUSE),
                                                True)
    f, pdf_lobes = lobes.bsdf_eval(SCRATCH, 0, UP, (0.0, 0.6, 0.8), lit_events(VISIBLE_DIFFUSE))
    assert (color, scale, pdf, valid) == (f, 1.0, pdf_lobes, False)


def test_lit_events_maps_visibility_to_lobe_events():
    assert lit_events(VISIBLE_DIFFUSE) == 1 << lobes.DIFFUSE_EVENT
    assert lit_events(VISIBLE_GLOSSY) == 1 << lobes.REFLECT_EVENT
    assert lit_events(VISIBLE_TRANSMISSION) == 1 << lobes.TRANSMIT_EVENT
    assert lit_events(VISIBLE_CAMERA) == 0
