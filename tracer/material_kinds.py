"""The kernels' material kind codes: which code path scatters at a hit.

materials.kind_code gives each scene material one: the smooth kinds keep their exact code paths
(scatter.py's scatter_lit and scatter_specular, with specular.py), LAYERED is every rough or
Principled material, whose lobes lobes.py builds per hit (scatter_lit), PROGRAM a material
whose node tree was compiled to a shader program (scatter_program). A module of its own
because specular.py needs the codes and materials.py imports lobes.py, which imports specular.py.
"""
DIFFUSE, MIRROR, GLASS, REFRACTION, EMISSION, LAYERED = range(6)
# A shader program (shader/program.py) builds the hit's lobes, emission and transparency.
PROGRAM = 6
