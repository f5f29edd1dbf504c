"""What the tests share (tests/conftest.py puts tests/ on sys.path, so `from support import ...`).

- paths: the repository's folders (ROOT, TESTS, SCENES, SUPPORT).
- builders: Snell scenes built in code (meshes, cameras, make_scene, tiny_scene).
- stats: the statistics harness (Sidak, z bounds, chi-square goodness of fit over sphere bins,
  estimators that must agree), after Mitsuba 3's chi2.py.
- microfacet: the shipped microfacet tables and their standard errors.
- cycles_reference: a Cycles reference and Snell renders compared against it.
- hdri: HDRI images and worlds for the environment tests (bpy).
- Scripts run in a subprocess (they reset bpy or wrap `snell`): blender_scenes.py,
  corpus_blends.py, blend_fuzz.py, interrupt_hook.py, fault_hook.py.
"""
