"""The kernels' material kind codes: which code path scatters at a hit.

materials.kind_code gives each scene material one: the smooth kinds keep their exact code paths
(diffuse.py, specular.py), LAYERED is every rough or Principled material, whose lobes lobes.py
builds per hit (layered.py). A module of its own because specular.py needs the codes and
materials.py imports lobes.py, which imports specular.py.
"""
DIFFUSE, MIRROR, GLASS, REFRACTION, EMISSION, LAYERED = range(6)
