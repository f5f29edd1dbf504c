"""`snell bench`: the --quick smoke run (every JSON key filled, finite) and its pure-Python parts.

Speed is never asserted: only that the numbers exist, are finite and are consistent with each other.
"""
import json
import math
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

from snell.validation import bench, bench_curves, bench_report
from snell.validation import metrics

from support.paths import ROOT as REPO  # noqa: E402
SCENES = [os.path.join(REPO, "scenes", n) for n in ("cornell_spheres.blend", "cornell_dragon.blend")]


def _points(times, errs):
    return [{"wall_s": t, "relmse": e} for t, e in zip(times, errs)]


def test_time_at_error_interpolates_log_log():
    # relMSE = 1 / t exactly: the time at error e is 1 / e
    t = [1.0, 2.0, 4.0, 8.0]
    e = [1.0, 0.5, 0.25, 0.125]
    assert bench_curves.time_at_error(t, e, 0.3) == pytest.approx(1 / 0.3)
    assert bench_curves.time_at_error(t, e, 2.0) == 1.0      # reached at the first point
    assert bench_curves.time_at_error(t, e, 0.1) is None     # never reached
    # the first crossing counts, even if the curve comes back up (noise)
    assert bench_curves.time_at_error([1, 2, 4], [1.0, 0.2, 0.5], 0.5) == pytest.approx(
        math.exp(math.log(2) * math.log(2) / math.log(5)))


def test_equal_error_ratio_and_target():
    snell = _points([2, 4, 8, 16], [0.8, 0.4, 0.2, 0.1])        # relMSE x time = 1.6
    cycles = _points([1, 2, 4], [0.8, 0.4, 0.2])                # relMSE x time = 0.8
    eq = bench_curves.equal_error(snell, cycles)
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
    c = metrics.compare(img, np.full(ref.shape, 0.01), 10, ref, np.full(ref.shape, 0.01), 10)
    assert c["relmse"] == pytest.approx(metrics.relmse(img, ref))
    errs = bench_curves.errors(img, metrics.Estimate(ref, np.zeros(ref.shape), 15))
    assert errs["rmse"] == pytest.approx(c["rmse"])


def _noisy_reference(seed, shape=(96, 96), seeds=16):
    """(true image mu, a reference of `seeds` heavy-tailed samples (gamma of shape 0.5: the
    relative spread of a caustic's), its variance of the mean)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:shape[0], :shape[1]] / shape[0]
    mu = np.stack([0.3 + 2.0 * x * y, 1.0 + np.sin(6 * x), 0.5 + y], -1)
    mu[40:56, 40:56] *= 8.0                                  # a bright patch with sharp edges
    samples = mu * rng.gamma(0.5, 2.0, (seeds, *mu.shape))
    return mu, samples.mean(0), samples.var(0, ddof=1) / seeds


def test_the_bench_relmse_takes_the_references_noise_out():
    """Against a noisy reference (16 heavy-tailed samples per pixel: its own plain relMSE 0.10,
    as the tumbler's caustic region's) the bench's relMSE of an image 20% off the truth is
    within 10% of its relMSE against the truth at the same pixel weights (measured 0.0358
    against 0.0370), where the plain relMSE is ten times it (0.373). And it ranks images as the
    truth does: the true image first (0.0010), 10% darker (0.0055) or brighter (0.0067) after;
    the plain relMSE ranks the darker one first (0.146 < 0.195). Deliberate errors caught: the
    reference's variance left in (0.116 for the true image); R^2 the weight (the darker image
    first, 0.052 < 0.103)."""
    mu, ref, var = _noisy_reference(3)
    image = mu * 1.2
    truth = metrics.relmse_against_estimate(image, mu, np.zeros(mu.shape))
    assert metrics.relmse_against_estimate(image, ref, var) == pytest.approx(truth, rel=0.1)
    assert metrics.relmse(image, ref) > 5 * truth
    scores = {k: metrics.relmse_against_estimate(mu * k, ref, var) for k in (0.9, 1.0, 1.1)}
    assert scores[1.0] < 0.5 * min(scores[0.9], scores[1.1]), scores
    assert metrics.relmse(mu * 0.9, ref) < metrics.relmse(mu, ref)     # the plain rule's bias


def test_the_bench_relmse_is_never_below_its_standard_error():
    """The true image scores the standard error of the mean of its terms (measured 0.0010), not
    0 or below (the curves take its logarithm); an image of another seed scores its noise
    (0.116)."""
    mu, ref, var = _noisy_reference(3)
    exact = metrics.relmse_against_estimate(mu, ref, var)
    assert 0.0 < exact < 0.002
    _, other, _ = _noisy_reference(4)
    assert metrics.relmse_against_estimate(other, ref, var) > 20 * exact


def test_neighbour_mean_leaves_each_pixel_out():
    """A pixel's own value never moves its neighbours' mean, at the edges included; a constant
    image's is the constant; a single pixel has none and keeps its value."""
    rng = np.random.default_rng(0)
    x = rng.uniform(size=(5, 6, 3))
    base = metrics.neighbour_mean(x)
    for i in range(5):
        for j in range(6):
            moved = x.copy()
            moved[i, j] += 10.0
            assert np.allclose(metrics.neighbour_mean(moved)[i, j], base[i, j], atol=1e-12)
    assert np.allclose(metrics.neighbour_mean(np.full((4, 7, 3), 2.0)), 2.0)
    assert np.allclose(metrics.neighbour_mean(np.full((1, 1, 3), 2.0)), 2.0)


def test_cache_key_and_roundtrip(tmp_path):
    blend = tmp_path / "a.blend"
    blend.write_bytes(b"abc")
    k1 = bench.cache_key(blend, {"spp": 4}, "5.0.1")
    assert k1 == bench.cache_key(blend, {"spp": 4}, "5.0.1")
    assert k1 != bench.cache_key(blend, {"spp": 8}, "5.0.1")
    assert k1 != bench.cache_key(blend, {"spp": 4}, "5.1.0")
    blend.write_bytes(b"abd")
    assert k1 != bench.cache_key(blend, {"spp": 4}, "5.0.1")
    assert bench.cache_load(tmp_path, k1) is None
    m = np.ones((2, 3, 3))
    bench.cache_store(tmp_path, k1, m, m * 0.5, {"render_s": 1.5})
    mean, var, meta = bench.cache_load(tmp_path, k1)
    assert np.allclose(mean, 1) and np.allclose(var, 0.5) and meta == {"render_s": 1.5}


def test_missing_values_finds_nulls():
    assert bench_report.missing_values({"a": [1.0, {"b": 2}]}) == []
    assert bench_report.missing_values({"a": [1.0, {"b": None}], "c": float("nan")}) == ["a[1].b", "c"]


@pytest.mark.skipif(not all(map(os.path.isfile, SCENES)), reason="reference scenes not built")
def test_median_run_keeps_one_whole_run():
    """The kept run is the median by wall time, whole (its parts add up), with the largest peak."""
    runs = [{"wall_s": 12.0, "render_s": 11.0, "export_s": 1.0, "peak_rss_mb": 300},
            {"wall_s": 10.0, "render_s": 7.0, "export_s": 3.0, "peak_rss_mb": 310},
            {"wall_s": 11.0, "render_s": 10.5, "export_s": 0.5, "peak_rss_mb": 305}]
    p = bench_curves.median_run(runs)
    assert (p["wall_s"], p["render_s"], p["export_s"]) == (11.0, 10.5, 0.5)
    assert p["peak_rss_mb"] == 310 and p["runs"] == 3 and p["wall_s_runs"] == [12.0, 10.0, 11.0]
    assert bench_curves.median_run(runs[:2])["wall_s"] == 10.0           # even count: the lower median
    assert bench_curves.median_run(runs[:1]) == {**runs[0], "runs": 1, "wall_s_runs": [12.0]}


@pytest.mark.slow        # a whole quick bench with its Cycles ladder: 84 s
def test_quick_bench_fills_every_key(tmp_path):
    pytest.importorskip("bpy")
    pytest.importorskip("flip_evaluator")
    report = tmp_path / "report"
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "bench", "--quick", "--report", str(report),
                           "--cache", str(tmp_path / "cache"), "--caustics", "both", "--quiet",
                           # one adaptive point per renderer and scene keeps the test short
                           "--thresholds", "0.1"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    data = json.loads((report / "bench.json").read_text())
    assert bench_report.missing_values(data) == []
    assert data["quick"] is True and len(data["scenes"]) == 2
    for sc in data["scenes"]:
        assert sc["reference"]["cached"] is False and sc["reference"]["spp"] == 4 * 64
        for r in ("snell", "snell_path_tracer", "cycles"):
            pts = sc[r]["points"]
            assert [p["spp"] for p in pts] == [4, 8, 16]
            # ladder points sample every pixel equally, whatever the scene's noise threshold
            assert all(p["mean_spp"] == p["spp"] == p["pixel_spp_min"] and p["saved_share"] == 0
                       for p in pts)
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
        # as users render: both adaptive at 0.1, at most 256 (--quick) samples per pixel
        from snell.tracer.adaptive import auto_min_spp
        ad = sc["adaptive"]
        for r in ("snell", "cycles"):
            (p,) = ad[r]["points"]
            assert p["threshold"] == 0.1 and p["spp"] == 256 and p["relmse"] > 0
            assert auto_min_spp(0.1) <= p["pixel_spp_min"] <= p["mean_spp"] <= p["pixel_spp_max"] <= 256
            assert p["saved_share"] == pytest.approx(1 - p["mean_spp"] / 256, abs=1e-6)
        (eq,) = ad["equal_threshold"]
        assert eq["ratio"] > 0 and ad["map_threshold"] == 0.1
        assert eq["time_ratio"] == pytest.approx(ad["snell"]["points"][0]["wall_s"]
                                                 / ad["cycles"]["points"][0]["wall_s"])
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
    assert dragon["snell"]["points"][0]["stages"]["dielectric sampling"] == {
        "runs": False, "why": "no smooth glass"}
    assert all("caustic_relmse" not in p and p["light_paths"] == 0 for p in dragon["snell"]["points"])
    html = (report / "bench.html").read_text()
    assert html.count("<polyline") == 6 and "cornell_dragon" in html
    assert "The light tracer's share of the image" in html
    assert "As users render" in html and html.count("samples per pixel at threshold 0.1") == 4
    assert "adaptive at threshold 0.1" in proc.stdout
    assert (report / "bench.svg").read_text().startswith("<svg")
    assert "Snell / Cycles" in proc.stdout


def _adaptive_points(thresholds, times, errs, mean_spp):
    return [{"threshold": t, "wall_s": w, "relmse": e, "mean_spp": m}
            for t, w, e, m in zip(thresholds, times, errs, mean_spp)]


def test_equal_threshold_interpolates_along_snells_curve():
    # Snell: relMSE = 0.1 / t; Cycles at each threshold reaches relMSE 0.05 and 0.0125.
    snell = _adaptive_points([0.01, 0.1], [8.0, 1.0], [0.0125, 0.1], [400, 50])
    cycles = _adaptive_points([0.1, 0.01], [1.0, 2.0], [0.05, 0.0125], [100, 800])
    eq = bench_curves.equal_threshold(snell, cycles)
    assert [e["threshold"] for e in eq] == [0.1, 0.01]          # loosest first
    loose, tight = eq
    # Snell needs t = 0.1 / 0.05 = 2 s for Cycles' 0.05, Cycles took 1 s
    assert loose["along"] == "snell" and loose["target_relmse"] == pytest.approx(0.05)
    assert loose["snell_s"] == pytest.approx(2.0) and loose["ratio"] == pytest.approx(2.0)
    assert loose["time_ratio"] == pytest.approx(1.0) and loose["relmse_ratio"] == pytest.approx(2.0)
    assert loose["mean_spp_ratio"] == pytest.approx(0.5)
    assert tight["snell_s"] == pytest.approx(8.0) and tight["ratio"] == pytest.approx(4.0)


def test_equal_threshold_swaps_roles_when_snell_never_gets_as_low():
    # Cycles goes lower than any Snell point: Snell's relMSE 0.02 at 0.01, Cycles' time to it
    # along its curve (relMSE = 0.04 / t: 2 s), Snell took 3 s.
    snell = _adaptive_points([0.1, 0.01], [1.0, 3.0], [0.05, 0.02], [50, 400])
    cycles = _adaptive_points([0.1, 0.01], [1.0, 4.0], [0.04, 0.01], [60, 500])
    tight = bench_curves.equal_threshold(snell, cycles)[1]
    assert tight["along"] == "cycles" and tight["target_relmse"] == pytest.approx(0.02)
    assert tight["cycles_s"] == pytest.approx(2.0) and tight["ratio"] == pytest.approx(1.5)
    # the summary's and the maps' threshold: nearest 0.01 in log scale
    assert bench_curves.nearest_threshold([0.1, 0.03, 0.003]) == 0.03    # log10 distances 0.48 < 0.52
    assert bench_curves.nearest_threshold([0.1, 0.005]) == 0.005         # 0.30 < 1


def test_sample_summary():
    s = bench_curves.sample_summary(np.array([[4, 8], [16, 4]]), 16)
    assert s == {"mean_spp": 8.0, "pixel_spp_min": 4, "pixel_spp_max": 16, "saved_share": 0.5}


def test_sample_map_ramp_and_vmax():
    from snell.pages import sample_map as sm
    counts = np.arange(12).reshape(3, 4) * 10            # 0 .. 110
    rgb = sm.sample_map_rgb(counts)
    assert rgb.shape == (3, 4, 3) and rgb.dtype == np.uint8
    # more samples are always lighter (viridis' lightness rises), ends at the ramp's ends
    lum = (rgb.astype(float) @ [0.2126, 0.7152, 0.0722]).ravel()
    assert np.all(np.diff(lum) > 0)
    assert (rgb[0, 0] == sm.VIRIDIS[0]).all() and (rgb[-1, -1] == sm.VIRIDIS[-1]).all()
    # vmax: the scale's top; counts above it clip to the bright end
    half = sm.sample_map_rgb(counts, vmax=220)
    assert (half[-1, -1] == sm.ramp(0.5)).all() and not (half[-1, -1] == rgb[-1, -1]).all()
    clipped = sm.sample_map_rgb(counts, vmax=55)
    assert (clipped[-1] == sm.VIRIDIS[-1]).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")                    # no division by 0
        assert (sm.sample_map_rgb(np.zeros((2, 2))) == sm.VIRIDIS[0]).all()
    with pytest.raises(ValueError):
        sm.sample_map_rgb(np.zeros((2, 2, 3)))


def test_sample_map_png_has_map_bar_and_caption(tmp_path):
    oiio = pytest.importorskip("OpenImageIO")
    from snell.pages import sample_map as sm
    counts = np.full((32, 64), 40)
    counts[:16] = 200
    path = tmp_path / "map.png"
    path.write_bytes(sm.sample_map_png(counts, vmax=256))
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(0, 0, 0, 3, "uint8")).reshape(spec.height, spec.width, 3)
    inp.close()
    k = sm.DISPLAY_WIDTH // 64                            # whole-pixel upscale
    assert spec.width == 64 * k and spec.height > 32 * k + sm.BAR_HEIGHT
    assert (pixels[0, 0] == sm.ramp(200 / 256)).all()
    assert (pixels[32 * k - 1, 0] == sm.ramp(40 / 256)).all()
    assert (pixels[32 * k, 0] == sm.VIRIDIS[0]).all() and (pixels[32 * k, -1] == sm.VIRIDIS[-1]).all()


def test_cycles_adaptive_settings():
    from snell.validation import cycles
    settings = {k: v for k, v, _ in cycles.adaptive_settings(8, 0.01, 1024, 5, 2)}
    assert settings["cycles.use_adaptive_sampling"] is True
    assert settings["cycles.adaptive_threshold"] == 0.01
    assert settings["cycles.adaptive_min_samples"] == 0            # Cycles' automatic minimum
    assert settings["cycles.samples"] == 1024                       # the cap, all of it rendered
    assert settings["cycles.use_sample_subset"] is False
    assert "cycles.sample_offset" not in settings and "cycles.sample_subset_length" not in settings
    assert settings["view_layers.cycles.pass_debug_sample_count"] is True
    assert settings["output"] == cycles.MULTILAYER
    # everything else is the validator's forced setting, which stays non-adaptive
    forced = {k: v for k, v, _ in cycles.forced_settings(8, 1024, 5, 2)}
    assert forced["cycles.use_adaptive_sampling"] is False and forced["cycles.use_sample_subset"]
    changed = {k for k in forced if settings.get(k, object()) != forced[k]}
    assert changed == {"cycles.samples", "cycles.use_adaptive_sampling", "cycles.use_sample_subset",
                       "cycles.sample_offset", "cycles.sample_subset_length", "output"}
    with pytest.raises(ValueError):
        cycles.adaptive_settings(8, 0.0, 1024, 5)


def test_cycles_samples_rendered_scale_its_sample_count_pass():
    """Cycles' Sample Count pass is each pixel's count over the samples it rendered, which stop
    early when every pixel converged (cornell_dragon at 0.1 stopped at 80 of 1024: read over
    1024 its pixels had 614 to 1024 samples in half a second; over 80, 48 to 80, 48 being
    Cycles' first check after its minimum of 32)."""
    from snell.validation import cycles
    lines = ["Remaining: 00:07.88 | Mem: 17M | Sample 64/1024",
             "Remaining: 00:06.24 | Mem: 17M | Sample 80/1024",
             "Remaining: 00:06.24 | Mem: 17M | Sample 0/1024"]      # the last line, after it
    assert cycles.samples_rendered(lines, 1024) == 80
    assert cycles.samples_rendered(["Mem: 17M"], 1024) == 1024        # no progress seen: the cap
    assert cycles.samples_rendered(["Sample 2048/2048"], 1024) == 1024


def test_thresholds_argument():
    import argparse
    from snell.validation.commands import thresholds
    assert thresholds("0.1,0.01") == (0.1, 0.01) and thresholds("none") == ()
    for bad in ("0.1,x", "0", "1.5"):
        with pytest.raises(argparse.ArgumentTypeError):
            thresholds(bad)
