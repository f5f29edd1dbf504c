"""The codes compiled code reads about lights: the kinds of light, and each lamp's flags."""
from __future__ import annotations

from ..jit import jit

# The kinds of light in the one distribution that picks them (tables.Lights.kind).
EMISSIVE_TRIANGLE, AREA, POINT, SUN, WORLD = range(5)
# Per-lamp flags: which rays see the lamp, whether its light samples cast shadows, and whether
# BSDF-sampled rays find it (Cycles' "multiple importance" option; without it a lamp lights by
# light samples only and only camera rays see it). Emissive triangles and the world have every
# flag.
VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION = 1, 2, 4, 8
CASTS_SHADOW, USES_MIS = 16, 32
# A lamp starts light vertices (light_vertices.py) only if camera paths treat it as a surface
# light: found by BSDF samples (MIS), blocked by geometry (shadows) and lighting diffuse vertices.
STARTS_LIGHT_VERTICES = USES_MIS | CASTS_SHADOW | VISIBLE_DIFFUSE
ZERO = (0.0, 0.0, 0.0)


@jit
def seen_by(flags, ray_kind):
    """Whether a ray of this kind (a VISIBLE_* flag) sees a lamp with these flags: camera rays
    only need the lamp to be visible to the camera, other rays also need its MIS option."""
    if not flags & ray_kind:
        return False
    return ray_kind == VISIBLE_CAMERA or (flags & USES_MIS) != 0
