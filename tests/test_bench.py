"""`snell bench`: the --quick smoke run (every JSON key filled, finite) and its pure-Python parts.

Speed is never asserted: only that the numbers exist, are finite and are consistent with each other.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from snell.compare import bench as cb
from snell.compare import metrics

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = [os.path.join(REPO, "scenes", n) for n in ("cornell_spheres.blend", "cornell_dragon.blend")]


def _points(times, errs):
    return [{"wall_s": t, "relmse": e} for t, e in zip(times, errs)]


def test_time_at_error_interpolates_log_log():
    # relMSE = 1 / t exactly: the time at error e is 1 / e
    t = [1.0, 2.0, 4.0, 8.0]
    e = [1.0, 0.5, 0.25, 0.125]
    assert cb.time_at_error(t, e, 0.3) == pytest.approx(1 / 0.3)
    assert cb.time_at_error(t, e, 2.0) == 1.0      # reached at the first point
    assert cb.time_at_error(t, e, 0.1) is None     # never reached
    # the first crossing counts, even if the curve comes back up (noise)
    assert cb.time_at_error([1, 2, 4], [1.0, 0.2, 0.5], 0.5) == pytest.approx(
        math.exp(math.log(2) * math.log(2) / math.log(5)))


def test_equal_error_ratio_and_target():
    snell = _points([2, 4, 8, 16], [0.8, 0.4, 0.2, 0.1])        # relMSE x time = 1.6
    cycles = _points([1, 2, 4], [0.8, 0.4, 0.2])                # relMSE x time = 0.8
    eq = cb.equal_error(snell, cycles)
    assert eq["target_relmse"] == pytest.approx(0.2)           # larger of the two minima
    assert eq["snell_s"] == pytest.approx(8) and eq["cycles_s"] == pytest.approx(4)
    assert eq["ratio"] == pytest.approx(2) and eq["fit_ratio"] == pytest.approx(2)
    assert eq["snell_slope"] == pytest.approx(-1) and eq["cycles_slope"] == pytest.approx(-1)


def test_relmse_drops_fireflies_and_matches_the_validator():
    rng = np.random.default_rng(1)
    ref = rng.uniform(0, 1, (32, 32, 3))
    img = ref + rng.normal(0, 0.1, ref.shape)
    img[0, 0, 0] = 1e6  # a firefly: dropped by the outlier rule (0.1 % of 3072 terms = 3)
    terms = np.sort(((img - ref) ** 2 / (ref ** 2 + metrics.RELMSE_EPS)).ravel())
    assert metrics.relmse(img, ref) == pytest.approx(terms[:-3].mean())
    errs = cb.errors(img, ref)
    c = metrics.compare(img, np.full(ref.shape, 0.01), 10, ref, np.full(ref.shape, 0.01), 10)
    assert errs["relmse"] == pytest.approx(c["relmse"]) and errs["relmse"] < 1
    assert errs["rmse"] == pytest.approx(c["rmse"])


def test_cache_key_and_roundtrip(tmp_path):
    blend = tmp_path / "a.blend"
    blend.write_bytes(b"abc")
    k1 = cb.cache_key(blend, {"spp": 4}, "5.0.1")
    assert k1 == cb.cache_key(blend, {"spp": 4}, "5.0.1")
    assert k1 != cb.cache_key(blend, {"spp": 8}, "5.0.1")
    assert k1 != cb.cache_key(blend, {"spp": 4}, "5.1.0")
    blend.write_bytes(b"abd")
    assert k1 != cb.cache_key(blend, {"spp": 4}, "5.0.1")
    assert cb.cache_load(tmp_path, k1) is None
    m = np.ones((2, 3, 3))
    cb.cache_store(tmp_path, k1, m, m * 0.5, {"render_s": 1.5})
    mean, var, meta = cb.cache_load(tmp_path, k1)
    assert np.allclose(mean, 1) and np.allclose(var, 0.5) and meta == {"render_s": 1.5}


def test_missing_values_finds_nulls():
    assert cb.missing_values({"a": [1.0, {"b": 2}]}) == []
    assert cb.missing_values({"a": [1.0, {"b": None}], "c": float("nan")}) == ["a[1].b", "c"]


@pytest.mark.skipif(not all(map(os.path.isfile, SCENES)), reason="reference scenes not built")
def test_median_run_keeps_one_whole_run():
    """The kept run is the median by wall time, whole (its parts add up), with the largest peak."""
    runs = [{"wall_s": 12.0, "render_s": 11.0, "export_s": 1.0, "peak_rss_mb": 300},
            {"wall_s": 10.0, "render_s": 7.0, "export_s": 3.0, "peak_rss_mb": 310},
            {"wall_s": 11.0, "render_s": 10.5, "export_s": 0.5, "peak_rss_mb": 305}]
    p = cb.median_run(runs)
    assert (p["wall_s"], p["render_s"], p["export_s"]) == (11.0, 10.5, 0.5)
    assert p["peak_rss_mb"] == 310 and p["runs"] == 3 and p["wall_s_runs"] == [12.0, 10.0, 11.0]
    assert cb.median_run(runs[:2])["wall_s"] == 10.0           # even count: the lower median
    assert cb.median_run(runs[:1]) == {**runs[0], "runs": 1, "wall_s_runs": [12.0]}


def test_quick_bench_fills_every_key(tmp_path):
    pytest.importorskip("bpy")
    pytest.importorskip("flip_evaluator")
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "bench", "--quick", "--report", str(report),
                           "--cache", str(tmp_path / "cache"), "--caustics", "both", "--quiet"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    data = json.loads((report / "bench.json").read_text())
    assert cb.missing_values(data) == []
    assert data["quick"] is True and len(data["scenes"]) == 2
    for sc in data["scenes"]:
        assert sc["reference"]["cached"] is False and sc["reference"]["spp"] == 4 * 64
        for r in ("snell", "snell_path_tracer", "cycles"):
            pts = sc[r]["points"]
            assert [p["spp"] for p in pts] == [4, 8, 16]
            for p in pts:
                assert p["wall_s"] > 0 and p["relmse"] > 0 and p["rmse"] > 0 and 0 < p["flip"] < 1
                assert p["peak_rss_mb"] > 0
                assert p["efficiency"] == pytest.approx(p["relmse"] * p["wall_s"])
            if r != "cycles":
                assert all(p["wall_s"] >= p["export_s"] + p["build_s"] + p["render_s"] - 1e-6 for p in pts)
                assert all(p["rays_per_second"] > 0 and 0 < p["embree_share"] <= 1 for p in pts)
        eq = sc["time_to_equal_error"]
        assert eq["ratio"] > 0 and eq["fit_ratio"] > 0
        assert eq["target_relmse"] == pytest.approx(max(min(p["relmse"] for p in sc["snell"]["points"]),
                                                        min(p["relmse"] for p in sc["cycles"]["points"])))
    # The spheres focus light (the light tracer runs, and the caustic region is measured on
    # its own); the dragon's box has no mirror or glass.
    spheres, dragon = data["scenes"]
    assert spheres["caustic_region"]["pixels"] > 0
    assert 0 < spheres["caustic_region"]["light_share_of_image"] < 0.5
    assert all(p["light_paths"] > 0 and p["caustic_relmse"] > 0 for p in spheres["snell"]["points"])
    assert all(p["light_paths"] == 0 for p in spheres["snell_path_tracer"]["points"])
    assert spheres["caustic_gain_at_equal_time"]["median"] > 0
    assert dragon["caustic_region"]["pixels"] == 0
    # What each scene skips: the dragon has no glass; neither has a world light.
    assert "dielectric sampling" in dragon["snell"]["points"][0]["skipped_stages"]
    assert "world" in spheres["snell"]["points"][0]["skipped_stages"]
    assert "dielectric sampling" not in spheres["snell"]["points"][0]["skipped_stages"]
    assert all("caustic_relmse" not in p and p["light_paths"] == 0 for p in dragon["snell"]["points"])
    html = (report / "bench.html").read_text()
    assert html.count("<polyline") == 6 and "cornell_dragon" in html
    assert "The light tracer's share of the image" in html
    assert (report / "bench.svg").read_text().startswith("<svg")
    assert "Snell / Cycles" in proc.stdout
