"""The view layer's light groups (View Layer > Light Groups) and who joins them: each lamp's
and object's Object > Shading > Light Group and the world's World > Settings > Light Group,
as Blender's Cycles sync reads them (blender/sync.cpp, object.cpp, light.cpp: a name the view
layer does not list is no group, LIGHTGROUP_NONE). The scene file holds the names and, on each
light, object and the world, an index into them (docs/scene-format.md, "Light groups")."""
from __future__ import annotations

# How the warning about a group the view layer does not list ends: Cycles renders it the same.
NOT_LISTED = "its light is in none (as in Cycles)"


class LightGroups:
    """The view layer's light group names and the index of each datablock's group."""

    def __init__(self, view_layer, warn):
        groups = getattr(view_layer, "lightgroups", None) or ()
        self.names = [group.name for group in groups]
        self._index = {name: i for i, name in enumerate(self.names)}
        self._warn = warn

    def entry(self, datablock, what: str) -> dict:
        """{"light_group": index} of a lamp, object or world (`what` names it in a warning),
        or {} when it is in no group."""
        name = getattr(datablock, "lightgroup", "") or ""
        if not name:
            return {}
        if name not in self._index:
            self._warn(f"{what}: light group {name!r} is not one of the view layer's light "
                       f"groups: {NOT_LISTED}")
            return {}
        return {"light_group": self._index[name]}
