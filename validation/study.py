"""`snell study depth|focus|aperture`: the seed's parameter sweeps, Snell and Cycles side by side.

depth    max depth 0, 1, 2, 3, 4, 5, 100 (the mirror-and-glass Cornell box); depth 0 has no
         Cycles equivalent and is shown for Snell alone.
focus    aperture radius 0.1 m at focal distances 2.9, 3.3, 3.7, 4.1 m (the detailed-mesh scene).
aperture radius 0.02, 0.09, 0.16, 0.23 m at focal distance 3.3 m.

Units: the reference scenes are built in metres with the seed's proportions (a 2 m Cornell box,
the camera 3.3 m from the mesh centre, see scenes/cornell_dragon.py), so the seed's lens radius b
and focal distance d are used unchanged: Snell gets dof.aperture_radius = b and focus_distance = d,
Cycles gets aperture_fstop = lens_mm * 1e-3 / (2 b) and the same focus distance.
"""
from __future__ import annotations

from . import compare

STUDIES = {
    "depth": [{"max_depth": m} for m in (0, 1, 2, 3, 4, 5, 100)],
    "focus": [{"aperture_radius": 0.1, "focus_distance": d} for d in (2.9, 3.3, 3.7, 4.1)],
    "aperture": [{"aperture_radius": r, "focus_distance": 3.3} for r in (0.02, 0.09, 0.16, 0.23)],
}

NOTES = {
    "depth": ["Max depth m = emission plus up to m bounces = Cycles max_bounces m - 1 (per-kind "
              "limits equal). Depth 0 (emitters seen directly) has no Cycles equivalent."],
    "focus": ["Scene in metres with the seed's proportions (2 m box, camera 3.3 m from the mesh "
              "centre): the seed's lens radius and focal distance are used unchanged. Cycles: "
              "aperture_fstop = lens_mm * 1e-3 / (2 radius)."],
    "aperture": ["Scene in metres with the seed's proportions: the seed's lens radius and focal "
                 "distance are used unchanged. "
                 "Cycles: aperture_fstop = lens_mm * 1e-3 / (2 radius)."],
}


def label(setting):
    if "max_depth" in setting:
        return f"max depth {setting['max_depth']}"
    return f"radius {setting['aperture_radius']:g} m, focus {setting['focus_distance']:g} m"


def run_study(name, blend_path, *, spp=None, seed=None, max_depth=None, scale=None,
              n_seeds=compare.DEFAULT_CYCLES_SEEDS, progress=None, threads=2):
    """[(setting, result dict)] for one study; each result as compare.compare_blend returns."""
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r} (expected one of {', '.join(STUDIES)})")
    rows = []
    for setting in STUDIES[name]:
        camera = {k: v for k, v in setting.items() if k != "max_depth"}
        depth = setting.get("max_depth", max_depth)
        if progress is not None and progress.enabled:
            progress.line(f"study {name}: {label(setting)}", final=True)
        result = compare.compare_blend(blend_path, spp=spp, max_depth=depth, seed=seed, scale=scale,
                                       n_seeds=n_seeds, threads=threads, progress=progress,
                                       camera=camera or None)
        result["label"] = label(setting)
        result["setting"] = dict(setting)
        rows.append(result)
    return rows
