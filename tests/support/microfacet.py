"""The shipped microfacet tables and their standard errors (the tables' own Monte Carlo error),
shared by tests/unit/test_microfacet_tables.py and test_lobes.py."""
import numpy as np

from snell.tracer.microfacet_tables import TABLES_PATH, load_tables

TABLES = load_tables()
with np.load(TABLES_PATH) as _data:
    STANDARD_ERRORS = {name: _data["se_" + name].astype(np.float64)
                       for name in TABLES._fields}
