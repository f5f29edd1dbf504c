"""Blender's colour configuration as Cycles reads it, for the nodes that convert colours.

Blender's OpenColorIO config (datafiles/colormanagement/config.ocio): scene linear is Linear
Rec.709, whose matrix from CIE XYZ (D65) is XYZ_TO_REC709. Cycles derives its xyz_to_rgb from
the config's aces_interchange role (scene/shader.cpp init_xyz_transforms), which comes to this
matrix; rgb_to_y (RGB_TO_Y: a colour linked to a number, RGB to BW) is the Y row of its inverse,
and Blackbody's rec709_to_rgb is the identity.
"""
from __future__ import annotations

import numpy as np

XYZ_TO_REC709 = ((3.2409699, -1.5373832, -0.4986108),
                 (-0.9692436, 1.8759675, 0.0415551),
                 (0.0556301, -0.2039770, 1.0569715))
RGB_TO_Y = tuple(float(v) for v in np.linalg.inv(np.array(XYZ_TO_REC709))[1])
