"""A Cycles reference rendered once, and Snell renders compared against it (the validator's
statistics, snell.validation.compare), shared by the tests that hold scenes against Cycles."""
from __future__ import annotations

SPP = 256       # samples per pixel in both renderers: Cycles as 8 seeds of SPP / 8
SCALE = 25      # resolution percentage (64x64 of the reference scenes' 256x256)
SEED = 0


class Reference:
    """A Cycles reference plus the exported Snell scene at the test resolution."""

    def __init__(self, blend, dof=None, framing=None, max_depth=None, spp=SPP, cycles_seeds=8):
        from snell.validation import compare
        self.blend, self.spp = blend, spp
        scene, self.warnings = compare.load_snell_scene(blend)
        dof, framing = dict(dof or {}), dict(framing or {})
        framing = {"resolution_percentage": SCALE, **framing}
        scene = scene.with_camera(**framing).with_render(
            spp=spp, seed=SEED, max_depth=max_depth)
        if dof:
            scene = scene.with_camera(dof={"use_dof": True, **dof})
        self.scene = scene
        self.cycles = compare.cycles_render(blend, spp=spp, max_depth=scene.render["max_depth"],
                                            seed=SEED, camera={**dof, **framing},
                                            n_seeds=cycles_seeds)

    def compare(self, modify=lambda s: s, noise_threshold=0.0, spp=None):
        """The validator's report dict for Snell (modify: a deliberate change) against Cycles."""
        from snell.validation import compare
        from snell.tracer.integrator import Renderer
        scene = modify(self.scene)
        result = compare.snell_render(scene, spp or self.spp, noise_threshold=noise_threshold)
        index = Renderer(scene, caustics=False, light_vertices=False).object_index()
        return compare.compare_renders(result, self.cycles, settings=compare.snell_settings(scene),
                                       objects=(index, [o["name"] for o in scene.objects]))


def verdict(result):
    """(verdict, the numbers an assertion message should show)."""
    detail = {k: result[k] for k in ("tests", "z_pass_fraction", "tiles_failed", "mean_z",
                                     "mean_ratio", "sharpness_z")}
    return result["verdict"], detail
