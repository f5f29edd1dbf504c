"""A scene's lights, one module per kind and one place that switches on the kind.

- codes.py: the kinds of light and each lamp's visibility, shadow and MIS flags.
- triangles.py: emissive triangles (mesh emitters).
- area.py, point.py (point and spot), sun.py: Blender's lamps as Cycles renders them.
- world.py: the world, a colour or an equirectangular environment map (the HDRI world).
- dispatch.py: pick a light, then its sample, density, hit and emission by kind.
- tables.py: the tables compiled code reads (Lights) and LightSampler, which builds them.

Each kind's module holds its sampling for next-event estimation, the density of that sampling,
what a ray that hits it gets, and its emission for the light tracer and light vertices.
"""
