"""A glass standing exactly on a table: warned, and not comparable with Cycles
(addon/export/contacts.py)."""
import importlib

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402

common = importlib.import_module("common")


def glass_on_table(lift):
    """A 0.4 m glass cube on a 4 m table, its base `lift` above the table's top."""
    scene = common.reset()
    common.camera(scene, (0.0, -10.0, 2.0), (0.0, 0.0, 0.0))
    common.floor("Table", 2, common.material("Top", "diffuse", (0.8, 0.8, 0.8)))
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.3, 0.2, 0.2 + lift))
    bpy.context.active_object.name = "Tumbler"
    bpy.context.active_object.data.materials.append(
        common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5))
    return export.export_depsgraph(bpy.context.evaluated_depsgraph_get())[1]


def test_a_glass_standing_exactly_on_a_table_is_warned_as_not_comparable():
    (warning,) = glass_on_table(0.0)
    assert warning.startswith("object 'Tumbler': refracting faces lie on object 'Table''s faces")
    assert export.differs_from_cycles(warning)


def test_a_glass_lifted_a_tenth_of_a_millimetre_is_not_warned():
    assert glass_on_table(1e-4) == []
