"""The shipped microfacet tables and their standard errors (the tables' own Monte Carlo error),
shared by tests/unit/test_microfacet_tables.py and test_lobes.py, and a Principled BSDF's lobes
(test_lobes.py, test_caustics_lobes.py)."""
import numpy as np

from snell.tracer import lobes
from snell.tracer.microfacet_tables import TABLES_PATH, load_tables

TABLES = load_tables()
with np.load(TABLES_PATH) as _data:
    STANDARD_ERRORS = {name: _data["se_" + name].astype(np.float64)
                       for name in TABLES._fields}


UP = (0.0, 0.0, 1.0)


def principled_bsdf(wi, entering=True, base=(0.8, 0.8, 0.8), dist=lobes.DIST_MULTI_GGX, drop=0,
                    **params):
    """(lobes array, count) of a Principled BSDF about +z with Blender's defaults but for
    `params` (lobes.P_* names in lower case), dropping the caustics `drop`
    (path_limits.dropped_at)."""
    p = np.zeros(lobes.P_FIELDS)
    defaults = {"roughness": 0.5, "ior": 1.5, "specular_level": 0.5, "coat_roughness": 0.03,
                "coat_ior": 1.5, "metallic": 0.0, "transmission": 0.0, "coat": 0.0}
    defaults.update(params)
    for name, value in defaults.items():
        p[getattr(lobes, "P_" + name.upper())] = value
    p[lobes.P_SPECULAR_TINT:lobes.P_SPECULAR_TINT + 3] = 1.0
    p[lobes.P_COAT_TINT:lobes.P_COAT_TINT + 3] = 1.0
    rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    count = lobes.setup_principled(rows, TABLES, UP, UP, wi, entering, base, p, dist, drop)
    return rows, count
