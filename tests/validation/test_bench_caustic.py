"""`snell bench --caustic-scenes` (issue 34's bench targets): the scene list the flag selects, the
targets' arithmetic, the references' Cycles settings, and a tiny run whose figures must all exist
and be finite. Speed is never asserted.
"""
import json
import math
import os
import subprocess
import sys

import pytest

from snell.errors import CliError
from snell.validation import bench, bench_curves, bench_report, bench_scenes, cycles
from snell.validation.commands import bench_scene_list
from snell.cli import build_parser

NAMES = ["sun_caustic", "hdri_caustic", "pool", "tumbler_caustic"]
# The files that set Cycles' shadow caustics (scenes/*.py: common.shadow_caustics), where
# Snell's stage runs unless the setup turns it off.
FLAGGED = {"sun_caustic", "pool", "tumbler_caustic"}


def _ladder(times, errs, caustic):
    return [{"spp": 2 ** k, "wall_s": t, "relmse": e, "caustic_relmse": c}
            for k, (t, e, c) in enumerate(zip(times, errs, caustic))]


def test_caustic_targets_from_the_ladders():
    """Snell's caustic relMSE a tenth of Cycles' at every time, its whole image at equal error
    in 0.4 of Cycles' time: both targets met; the ladder without the strategy (caustic relMSE
    twice Cycles', time ratio 2) meets neither."""
    times = [1.0, 2.0, 4.0, 8.0]
    cycles_points = _ladder(times, [0.8 / t for t in times], [1.0 / t for t in times])
    scene = {"cycles": {"points": cycles_points},
             "snell": {"points": _ladder(times, [0.32 / t for t in times],
                                         [0.1 / t for t in times])},
             "snell_without": {"points": _ladder(times, [1.6 / t for t in times],
                                                 [2.0 / t for t in times])}}
    t = bench_curves.caustic_targets(scene)
    s, w = t["snell"], t["snell_without"]
    assert s["caustic_relmse_ratio"] == pytest.approx(0.1) and s["caustic_met"]
    assert s["time_ratio"] == pytest.approx(0.4) and s["time_met"]
    assert not s["caustic_extrapolated"]
    assert w["caustic_relmse_ratio"] == pytest.approx(2.0) and not w["caustic_met"]
    assert w["time_ratio"] == pytest.approx(2.0) and not w["time_met"]
    # Every Snell point faster than every Cycles point (Cycles' fixed costs): an upper bound,
    # Snell's slowest point over Cycles' lowest error.
    late = {**scene, "cycles": {"points": _ladder([10.0, 20.0], [0.1, 0.05], [0.2, 0.1])}}
    b = bench_curves.caustic_targets(late)["snell"]
    assert b["caustic_how"] == "bound" and b["caustic_relmse_ratio"] == pytest.approx(0.125)
    # No caustic region: no figure, not met.
    for points in (scene["snell"]["points"], cycles_points):
        for p in points:
            del p["caustic_relmse"]
    t = bench_curves.caustic_targets(scene)
    assert math.isnan(t["snell"]["caustic_relmse_ratio"]) and not t["snell"]["caustic_met"]


def _args(*argv):
    return build_parser().parse_args(["bench", "--report", "/tmp/unused", *argv])


def test_the_flag_selects_the_caustic_scenes(monkeypatch, tmp_path):
    """--caustic-scenes benches the four caustic scenes with their setups, built into the cache;
    with SCENEs too it is an error; without it, the default scenes are unchanged."""
    built = []

    def fake_build(cache_dir, log=None, scenes=bench_scenes.CAUSTIC_SCENES):
        built.append(cache_dir)
        return [(os.path.join(cache_dir, f"{s.name}.blend"), s) for s in scenes]

    monkeypatch.setattr(bench_scenes, "build", fake_build)
    scenes, setups = bench_scene_list(_args("--caustic-scenes", "--cache", str(tmp_path)),
                                      bench, print)
    assert [os.path.basename(p) for p in scenes] == [f"{n}.blend" for n in NAMES]
    assert built == [str(tmp_path)] and set(setups) == set(scenes)
    assert [setups[p].name for p in scenes] == NAMES
    # shadow caustics (MNEE) against none on the scenes seen through glass, light paths on the
    # others; merging (biased) on none
    assert [setups[p].without.get("shadow_caustics", True) for p in scenes] == [True, True,
                                                                                False, False]
    assert not any(setups[p].snell.get("photon_merging", "off") == "on" for p in scenes)
    assert [setups[p].biased for p in scenes] == [False, False, False, False]
    assert [setups[p].reference for p in scenes] == ["snell", "cycles", "cycles", "cycles"]
    scenes, setups = bench_scene_list(_args("--caustic-scenes", "pool,sun_caustic"), bench,
                                      print)
    assert [setups[p].name for p in scenes] == ["pool", "sun_caustic"]
    for argv in (("x.blend", "--caustic-scenes"), ("--caustic-scenes", "pool,lake")):
        with pytest.raises(CliError):
            bench_scene_list(_args(*argv), bench, print)
    if all(map(os.path.isfile, bench.DEFAULT_SCENES)):
        assert bench_scene_list(_args(), bench, print) == (bench.DEFAULT_SCENES, {})


def test_reference_clears_the_files_shadow_caustics(tmp_path):
    """The references render without Cycles' shadow caustics (biased), the ladders with the
    file's flags: pool.py sets them, SHADOW_CAUSTICS False clears every one, True keeps them."""
    bpy = pytest.importorskip("bpy")
    from snell.addon.blendfile import open_blend
    path = str(tmp_path / "pool.blend")
    subprocess.run([sys.executable, os.path.join(bench_scenes.SCENES_DIR, "pool.py"), path],
                   check=True, capture_output=True, timeout=300)

    def flags():
        objects = bpy.context.scene.objects
        return (objects["Lamp"].data.cycles.is_caustics_light,
                objects["Water"].cycles.is_caustics_caster,
                objects["Floor"].cycles.is_caustics_receiver)

    setup = next(s for s in bench_scenes.CAUSTIC_SCENES if s.name == "pool")
    for settings, expected, guiding in ((setup.cycles_settings(), (True,) * 3, setup.guiding),
                                        (bench_scenes.PLAIN_REFERENCE, (False,) * 3, False)):
        open_blend(path)
        cycles._apply(bpy.context.scene, settings)
        assert flags() == expected
        assert bpy.context.scene.cycles.use_guiding is guiding


@pytest.mark.slow        # four scenes, three tiny ladders and a reference each: 104 s (load 8)
def test_tiny_caustic_bench_fills_every_figure(tmp_path):
    pytest.importorskip("bpy")
    pytest.importorskip("flip_evaluator")
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "bench", "--caustic-scenes",
                           "--scale", "6", "--min-spp", "1", "--max-spp", "2", "--ref-seeds", "2",
                           "--ref-spp", "4", "--thresholds", "none", "--quiet",
                           "--report", str(report), "--cache", str(tmp_path / "cache")],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr
    data = json.loads((report / "bench.json").read_text())
    assert bench_report.missing_values(data) == []
    assert [sc["name"] for sc in data["scenes"]] == NAMES
    assert all(sc["caustic_region"]["reference_noise_relmse"] > 0 for sc in data["scenes"])
    for sc in data["scenes"]:
        ct = sc["caustic_targets"]
        assert ct["setup"]["name"] == sc["name"]
        assert sc["reference"]["renderer"] == ct["setup"]["reference"]
        for key in ("snell", "snell_without"):
            assert [p["spp"] for p in sc[key]["points"]] == [1, 2]
            figures = ct[key]
            for name in ("caustic_relmse_ratio", "time_ratio"):
                assert math.isfinite(figures[name]) and figures[name] > 0, (sc["name"], key)
        assert set(ct["equal_time"]) == {"snell", "snell_without", "cycles"}
        assert (report / f"equal_time_{sc['name']}.png").stat().st_size > 0
        for key, settings in (("snell", "snell"), ("snell_without", "without")):
            runs = sc["name"] in FLAGGED and ct["setup"][settings].get("shadow_caustics", True)
            stage = sc[key]["points"][0]["stages"]["shadow caustics"]
            assert stage["runs"] is runs, (sc["name"], key, stage)
    sun = data["scenes"][0]
    # Without the light tracer no light path leaves the sun of angle 0.
    assert all(p["light_paths"] > 0 for p in sun["snell"]["points"])
    assert all(p["light_paths"] == 0 for p in sun["snell_without"]["points"])
    html = (report / "bench.html").read_text()
    assert "Caustic scenes (issue 34)" in html and html.count("equal time: reference") == 4
