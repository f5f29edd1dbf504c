"""The media functions (tracer/media.py) directly: Beer-Lambert attenuation, the stack's entering
and leaving as Cycles' volume_stack_enter_exit does them, overlapping media, a shadow ray's
stack through its surface, and the stack at a point found by a ray straight up."""
from __future__ import annotations

import math

import numpy as np
import pytest

from support import builders
from snell.tracer import media
from snell.tracer.media import MAX_MEDIA, NONE


def _media(sigma, volume=None, object_of=(0, 1, 2, 3)):
    sigma = np.asarray(sigma, np.float64)
    n = len(sigma)
    volume = np.ones(n, bool) if volume is None else np.asarray(volume, bool)
    return media.Media(True, sigma, volume, n, np.asarray(object_of, np.int64),
                       media.empty_stacks(1)[0], media.empty_stacks(0), media.empty_stacks(0),
                       media.empty_stacks(0))


def _stack(*entries):
    stacks = media.empty_stacks(1)
    stacks[0, :len(entries)] = entries
    return stacks


def test_transmittance_is_beer_lambert():
    """exp(-sigma t) per channel; a clear channel is 1 even over an infinite segment (0 x inf
    would be NaN), an absorbing one 0. (Measured: with -sigma t / 2 in the exponent it fails.)"""
    tr = media.transmittance((0.2, 1.0, 0.0), 1.0)
    assert tr == pytest.approx((math.exp(-0.2), math.exp(-1.0), 1.0), rel=1e-15)
    assert media.transmittance((0.0, 3.0, 0.0), math.inf) == (1.0, 0.0, 1.0)
    assert media.through((2.0, 2.0, 2.0), (0.0, 0.0, 0.0), 1e30) == (2.0, 2.0, 2.0)


def test_enter_adds_once_and_leave_removes():
    """Entering adds the entry at the end unless it is there; leaving removes it, the last entry
    taking its place (Cycles' volume_stack_exit). (Measured: a leave that blanks the entry
    without moving the last one into its place fails.)"""
    stacks = media.empty_stacks(1)
    media.enter(stacks, 0, 5)
    media.enter(stacks, 0, 7)
    media.enter(stacks, 0, 5)
    assert list(stacks[0, :3]) == [5, 7, NONE]
    media.enter(stacks, 0, 9)
    media.leave(stacks, 0, 5)
    assert list(stacks[0, :3]) == [9, 7, NONE]
    media.leave(stacks, 0, 4)                      # not in the stack: nothing changes
    assert list(stacks[0, :3]) == [9, 7, NONE]
    media.leave(stacks, 0, 7)
    media.leave(stacks, 0, 9)
    assert list(stacks[0]) == [NONE] * MAX_MEDIA


def test_a_full_stack_ignores_one_more():
    stacks = media.empty_stacks(1)
    for entry in range(MAX_MEDIA + 1):
        media.enter(stacks, 0, entry)
    assert list(stacks[0]) == list(range(MAX_MEDIA))
    media.leave(stacks, 0, MAX_MEDIA - 1)          # the last one leaves cleanly
    assert list(stacks[0]) == list(range(MAX_MEDIA - 1)) + [NONE]


def test_nested_media_enter_and_leave_through_front_and_back_faces():
    """Into glass (object 0), into the liquid in it (object 1), out of the liquid, out of the
    glass: entries are (object, material), entered at front faces and left at back faces; a
    material without a volume never enters. (Measured: a sigma_of that counts the first entry
    only fails here and in the overlap test.)"""
    m = _media([[0.1, 0.1, 0.1], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0]], volume=[True, True, False],
               object_of=[0, 1, 2])
    stacks = media.empty_stacks(2)
    media.pass_through(m, stacks, 0, 0, 0, True)          # triangle 0 (object 0), material 0
    media.pass_through(m, stacks, 0, 1, 1, True)          # triangle 1 (object 1), material 1
    assert list(stacks[0, :2]) == [0 * 3 + 0, 1 * 3 + 1]
    assert media.sigma_of(m, stacks, 0) == pytest.approx((1.1, 2.1, 3.1))
    media.pass_through(m, stacks, 0, 2, 2, True)          # no volume: nothing
    assert stacks[0, 2] == NONE
    media.carry(m, stacks, 0, stacks, 1, 1, 1, False, True)   # out of the liquid
    assert list(stacks[1, :2]) == [0, NONE]
    media.carry(m, stacks, 0, stacks, 1, 1, 1, False, False)  # reflected: the stack stays
    assert list(stacks[1, :2]) == [0, 4]
    assert media.sigma_of(m, stacks, 1) == pytest.approx((1.1, 2.1, 3.1))


def test_overlapping_media_add_their_coefficients():
    """Two objects of one material, overlapping: two entries, twice the coefficient (Cycles
    sums every volume's extinction); the same object entered twice counts once."""
    m = _media([[0.5, 0.25, 0.0]], object_of=[0, 1])
    stacks = media.empty_stacks(1)
    media.pass_through(m, stacks, 0, 0, 0, True)
    media.pass_through(m, stacks, 0, 1, 0, True)
    media.pass_through(m, stacks, 0, 1, 0, True)
    assert media.sigma_of(m, stacks, 0) == pytest.approx((1.0, 0.5, 0.0))


def test_a_shadow_ray_through_the_surface_enters_or_leaves():
    """sigma_through: a shadow ray leaving through the front face of a medium enters it (unless
    inside already), through the back face leaves it; the path's own stack is unchanged.
    (Measured: a shadow ray that keeps the medium it leaves fails.)"""
    m = _media([[1.0, 1.0, 1.0], [0.0, 0.5, 0.0]], object_of=[0, 1])
    outside = _stack()
    assert media.sigma_through(m, outside, 0, 0, 0, True) == (1.0, 1.0, 1.0)
    inside = _stack(0, 1 * 2 + 1)
    assert media.sigma_through(m, inside, 0, 0, 0, False) == (0.0, 0.5, 0.0)
    assert media.sigma_through(m, inside, 0, 0, 0, True) == (1.0, 1.5, 1.0)
    assert list(inside[0, :2]) == [0, 3]


def test_stack_at_a_point_by_a_ray_straight_up():
    """A box in a box: inside both, the inner then the outer (exits of objects never entered);
    between them the outer; outside, and below both (the ray enters each before leaving it),
    none. (Measured: with the face test reversed it fails.)"""
    outer_p, outer_t = builders.box((-2, -2, -2), (2, 2, 2))
    inner_p, inner_t = builders.box((-1, -1, -1), (1, 1, 1))
    corners = np.concatenate([outer_p[outer_t], inner_p[inner_t]]).astype(np.float64)
    objects = np.repeat([0, 1], [len(outer_t), len(inner_t)])
    materials = np.repeat([0, 1], [len(outer_t), len(inner_t)])
    volume = np.array([True, True])

    def at(point):
        stack = media.stack_at(point, corners, objects, materials, 2, volume)
        return [int(e) for e in stack if e != NONE]
    assert at((0.1, 0.2, 0.3)) == [1 * 2 + 1, 0 * 2 + 0]
    assert at((1.5, 0.2, 0.3)) == [0]
    assert at((3.0, 0.2, 0.3)) == []
    assert at((0.1, 0.2, -5.0)) == []
