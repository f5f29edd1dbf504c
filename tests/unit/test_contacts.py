"""Refracting faces lying on another object's (addon/export/contacts.py)."""
import numpy as np
import pytest

from snell.addon.export.contacts import refracting_contacts

FACES = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
         (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]


def box(lo, hi):
    """(vertices, triangles) of an axis-aligned box."""
    v = [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    return np.array(v, float), np.array(FACES)


def table():
    """A 2 m square facing up at z = 0 (its triangles wound so that it does)."""
    return (np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float),
            np.array([[0, 1, 2], [0, 2, 3]]))


def contacts(*objects, refracting=(1,)):
    """refracting_contacts of the objects ((vertices, triangles) each), those listed refracting."""
    positions, triangles, ids, offset = [], [], [], 0
    for k, (v, t) in enumerate(objects):
        positions.append(v)
        triangles.append(t + offset)
        ids += [k] * len(t)
        offset += len(v)
    ids = np.array(ids)
    return refracting_contacts(np.vstack(positions), np.vstack(triangles), ids,
                               np.isin(ids, refracting))


@pytest.mark.parametrize("lift, touches", [(0.0, True), (1e-7, True), (1e-4, False),
                                           (2e-3, False), (-1e-4, False)])
def test_a_glass_standing_on_a_table_touches_it_within_float_steps_only(lift, touches):
    glass = box((0.0, 0.0, lift), (0.2, 0.2, 0.2 + lift))
    assert contacts(table(), glass) == ([(1, 0)] if touches else [])


def test_faces_meeting_face_to_face_touch_and_at_an_edge_do_not():
    glass = box((0.0, 0.0, 0.5), (0.2, 0.2, 0.7))
    assert contacts(box((0.2, 0.0, 0.5), (0.4, 0.2, 0.7)), glass) == [(1, 0)]   # side by side
    assert contacts(box((0.2, 0.2, 0.5), (0.4, 0.4, 0.7)), glass) == []          # edge only
    assert contacts(box((0.2, 0.5, 0.5), (0.4, 0.7, 0.7)), glass) == []          # apart


def test_only_refracting_objects_are_reported_and_glass_on_glass_both_ways():
    glass = box((0.0, 0.0, 0.0), (0.2, 0.2, 0.2))
    assert contacts(table(), glass, refracting=()) == []
    assert contacts(table(), glass, refracting=(0, 1)) == [(0, 1), (1, 0)]


def test_a_tilted_contact_is_found_and_one_object_alone_has_none():
    glass_v, glass_t = box((0.0, 0.0, 0.0), (0.2, 0.2, 0.2))
    table_v, table_t = table()
    c, s = np.cos(0.3), np.sin(0.3)
    turn = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    assert contacts((table_v @ turn.T + 5.0, table_t), (glass_v @ turn.T + 5.0, glass_t)) == [
        (1, 0)]
    assert contacts((glass_v, glass_t)) == []


def test_faces_whose_plane_rounds_to_either_side_of_a_distance_step_still_touch():
    """The table and the glass's base 2e-13 apart, either side of half a distance step (2e-6
    here: the scene is 2 m across): their planes' distances round to neighbouring steps."""
    half_step = 0.5 * 1e-6 * 2.0
    table_v, table_t = table()
    table_v[:, 2] = half_step - 1e-13
    glass = box((0.0, 0.0, half_step + 1e-13), (0.2, 0.2, 0.2))
    assert contacts((table_v, table_t), glass) == [(1, 0)]
