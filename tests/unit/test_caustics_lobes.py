"""Cycles' caustics switches on the lobes of one hit (lobes.py, path_limits.py), as Cycles'
kernel/svm/closure.h builds its closures after a diffuse bounce with a switch off: the glossy
layers left out without dimming the layers below them, glass with that kind's tint 0."""
import math

import numpy as np
import pytest

from snell.tracer import lobes, path_limits
from snell.tracer.lights.codes import VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION
from support.microfacet import TABLES, principled_bsdf

UP = (0.0, 0.0, 1.0)
WI = (math.sqrt(1 - 0.7 ** 2), 0.0, 0.7)
BASE = (0.8, 0.5, 0.2)
REFLECTIVE, REFRACTIVE = path_limits.NO_REFLECTIVE_CAUSTICS, path_limits.NO_REFRACTIVE_CAUSTICS


def principled(drop, dist=lobes.DIST_MULTI_GGX):
    """The lobes of a Principled BSDF with coat, metallic and transmission, dropping `drop`."""
    rows, count = principled_bsdf(WI, base=BASE, dist=dist, drop=drop, roughness=0.3,
                                  coat_roughness=0.1, metallic=0.5, transmission=0.3, coat=0.5)
    return rows[:count]


def weight(row):
    return np.array(lobes.vec_at(row, lobes.WEIGHT))


def test_the_switches_drop_only_after_a_diffuse_ray():
    limits = path_limits.bounce_limits(8, 8, 1024, 1024, 1024,
                                       path_limits.caustics_bits(False, True))
    assert path_limits.dropped_at(limits, VISIBLE_DIFFUSE) == REFLECTIVE
    assert path_limits.dropped_at(limits, VISIBLE_GLOSSY) == 0
    assert path_limits.dropped_at(limits, VISIBLE_TRANSMISSION) == 0
    assert path_limits.caustics_bits(True, False) == REFRACTIVE
    assert path_limits.caustics_bits(True, True) == 0


def test_reflective_off_leaves_the_principled_base_undimmed():
    """Coat, metallic and specular left out; what is left below them is not dimmed by them
    (Cycles allocates no closure, so closure_layering_weight never runs); metallic and
    transmission still take their share of the weight; the transmission keeps its refraction."""
    full, dropped = principled(0), principled(REFLECTIVE)
    assert len(full) == 5 and len(dropped) == 2
    glass, base = dropped
    assert base[lobes.KIND] == lobes.LAMBERT
    np.testing.assert_allclose(weight(base), np.array(BASE) * (1 - 0.5) * (1 - 0.3), rtol=1e-12)
    assert np.all(weight(full[-1]) < weight(base))          # dimmed by coat and specular
    assert glass[lobes.TRANSMITS] == 1.0
    assert lobes.vec_at(glass, lobes.R_TINT) == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(lobes.vec_at(glass, lobes.T_TINT), np.sqrt(BASE))


def test_refractive_off_keeps_every_reflective_layer():
    """Only the transmission's refraction tint goes; its multiscatter compensation then assumes
    the reflection's average Fresnel (Cycles' generalized Schlick setup)."""
    full, dropped = principled(0), principled(REFRACTIVE)
    assert len(dropped) == 5
    for k in (0, 1, 3, 4):
        np.testing.assert_array_equal(dropped[k], full[k])
    glass = dropped[2]
    assert lobes.vec_at(glass, lobes.T_TINT) == (0.0, 0.0, 0.0)
    assert lobes.vec_at(glass, lobes.R_TINT) == (1.0, 1.0, 1.0)
    assert not np.array_equal(weight(glass), weight(full[2]))
    ggx = principled(REFRACTIVE, dist=lobes.DIST_GGX)[2]
    np.testing.assert_array_equal(weight(ggx), weight(principled(0, dist=lobes.DIST_GGX)[2]))


@pytest.mark.parametrize("drop", [REFLECTIVE, REFRACTIVE])
def test_glass_keeps_the_other_kind_only(drop):
    """Rough glass (GGX) with one kind dropped: every sample is of the other kind, and the
    value there is the undropped glass's."""
    rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    full = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    args = (TABLES, UP, WI, True, (1.0, 1.0, 1.0), (0.9, 0.9, 0.9), 0.3, lobes.DIST_GGX, 1.5)
    assert lobes.setup_glass(rows, *args, drop) == 1
    lobes.setup_glass(full, *args)
    rng = np.random.default_rng(7)
    kept = lobes.REFLECT_EVENT if drop == REFRACTIVE else lobes.TRANSMIT_EVENT
    seen = 0
    for u in rng.random((200, 3)):
        wo, f, _, event, valid = lobes.bsdf_sample(rows, 1, UP, WI, *u)
        if not valid:
            continue
        seen += 1
        assert event == kept
        value, _ = lobes.bsdf_eval(rows, 1, WI, wo, lobes.ALL_EVENTS)
        expected, _ = lobes.bsdf_eval(full, 1, WI, wo, lobes.ALL_EVENTS)
        np.testing.assert_allclose(value, expected, rtol=1e-12)
    assert seen > 150
    assert lobes.setup_glass(rows, *args, REFLECTIVE | REFRACTIVE) == 0


def test_glossy_and_refraction_go_with_their_own_switch():
    rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    assert lobes.setup_glossy(rows, TABLES, UP, WI, BASE, 0.3, lobes.DIST_GGX, REFLECTIVE) == 0
    assert lobes.setup_glossy(rows, TABLES, UP, WI, BASE, 0.3, lobes.DIST_GGX, REFRACTIVE) == 1
    assert lobes.setup_refraction(rows, UP, True, BASE, 0.3, lobes.DIST_GGX, 1.5,
                                  REFRACTIVE) == 0
    assert lobes.setup_refraction(rows, UP, True, BASE, 0.3, lobes.DIST_GGX, 1.5,
                                  REFLECTIVE) == 1
