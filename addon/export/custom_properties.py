"""The values Attribute nodes of type Object, Instancer and View Layer read: an object's (or its
data's, its instancer's, its particle settings') or the view layer's (or the scene's, the
world's) custom property or RNA property by name, as RGBA, as Blender looks them up for Cycles
(blenkernel object_dupli.cc: BKE_object_dupli_find_rgba_attribute,
BKE_view_layer_find_rgba_attribute and find_property_rgba; Cycles' blender/object.cpp
lookup_instance_property)."""
from __future__ import annotations

import numbers

NOT_FOUND = (0.0, 0.0, 0.0, 0.0)


def property_rgba(owner, name):
    """owner's property `name` as (r, g, b, a), or None: a custom property first, else an RNA
    path; a number (or boolean) v is (v, v, v, 1), an array of up to four numbers fills
    (0, 0, 0, 1) from the start; anything else is not found."""
    if owner is None or not name:
        return None
    try:
        value = owner[name] if name in owner.keys() else owner.path_resolve(name)
    except (ValueError, TypeError, AttributeError, KeyError):
        return None
    if isinstance(value, bool):
        return (1.0, 1.0, 1.0, 1.0) if value else (0.0, 0.0, 0.0, 1.0)
    if isinstance(value, numbers.Real):
        return (float(value),) * 3 + (1.0,)
    if isinstance(value, (str, bytes)):
        return None
    try:
        items = list(value.to_list() if hasattr(value, "to_list") else value)
    except TypeError:
        return None
    # Boolean arrays and arrays of more than four are not read (only float and int arrays).
    if not 0 < len(items) <= 4 or not all(isinstance(x, numbers.Real) and
                                          not isinstance(x, bool) for x in items):
        return None
    out = [0.0, 0.0, 0.0, 1.0]
    out[:len(items)] = [float(x) for x in items]
    return tuple(out)


def instance_rgba(inst, name, use_instancer):
    """An Attribute node's RGBA for a depsgraph instance (type Instancer: use_instancer): the
    instancer's particle settings, then the instancer (for an instance), then the object and
    its data; (0, 0, 0, 0) where none has it. (Instance attributes of geometry nodes, which
    Blender reads first, are not reachable from Python: not read.)"""
    obj = inst.object
    owners = []
    if use_instancer and inst.is_instance:
        system = getattr(inst, "particle_system", None)
        if system is not None:
            owners.append(system.settings)
        owners.append(inst.parent)
    owners += [obj, obj.data]
    for owner in owners:
        value = property_rgba(owner, name)
        if value is not None:
            return value
    return NOT_FOUND


def view_layer_rgba(depsgraph, name):
    """An Attribute node's RGBA of type View Layer: the view layer's property, then the
    scene's, then its world's; (0, 0, 0, 0) where none has it."""
    scene = depsgraph.scene
    for owner in (depsgraph.view_layer, scene, scene.world):
        value = property_rgba(owner, name)
        if value is not None:
            return value
    return NOT_FOUND
