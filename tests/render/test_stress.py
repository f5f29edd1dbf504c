"""`snell stress`: the --quick suite passes, every check has power, the report has stable keys.

Power: a case must fail when its analytic value is wrong by a little more than its bound, and
when the render is wrong (a scaled image, a 10% larger aperture), with the same fixed seeds.
"""
import dataclasses
import json
import math

import numpy as np
import pytest

from snell import cli
from snell.stress import runner
from snell.stress import cases as sc
from snell.stress import extremes
from snell.tracer import integrator


def _case(case_id):
    matches = [c for c in ALL_CASES() if c.id == case_id]
    assert matches, case_id
    return matches[0]


ALL_CASES = runner.all_cases   # the real matrix, also where a test replaces it
QUICK_FAMILY = sum(1 for c in ALL_CASES(quick=True) if c.check == sc.STATISTICAL)


def _run(cases):
    """Run some cases with the bound they have in the --quick suite."""
    return runner.run(cases, threads=2, family_size=QUICK_FAMILY)


# ---------------------------------------------------------------------------------------------
# Analytic values


def test_fresnel_and_slab_sums():
    assert sc.fresnel_unpolarised(1.0, 1.5) == pytest.approx(0.04, abs=1e-15)
    assert sc.fresnel_unpolarised(0.0, 1.5) == pytest.approx(1.0)
    f = 0.3
    assert sc.slab_transmission(f, None) == pytest.approx((1 - f) / (1 + f))
    assert sc.slab_transmission(f, 1) == 0.0
    assert sc.slab_transmission(f, 2) == sc.slab_transmission(f, 3) == pytest.approx((1 - f) ** 2)
    assert sc.slab_transmission(f, 4) == pytest.approx((1 - f) ** 2 * (1 + f * f))
    assert sc.slab_transmission(f, 200) == pytest.approx(sc.slab_transmission(f, None), rel=1e-15)


def test_polygon_second_moment_formula():
    """E[r^2] of a regular B-gon inscribed in the unit circle is (2 + cos(2 pi / B)) / 6."""
    rng = np.random.default_rng(1)
    for blades in (3, 6):
        p = rng.uniform(-1, 1, (400000, 2))
        angle = np.arctan2(p[:, 1], p[:, 0]) % (2 * np.pi / blades) - np.pi / blades
        inside = np.hypot(p[:, 0], p[:, 1]) * np.cos(angle) <= np.cos(np.pi / blades)
        r2 = (p[inside] ** 2).sum(axis=1)
        expected = (2 + math.cos(2 * math.pi / blades)) / 6
        assert r2.mean() == pytest.approx(expected, abs=4 * r2.std() / math.sqrt(r2.size))


# ---------------------------------------------------------------------------------------------
# Judging


def _fake(check, analytic=1.0, expected_failure=""):
    return sc.Case("fake", "test", "x", "y", check, analytic, None, expected_failure=expected_failure)


def test_judge_rules():
    z = 3.0
    exact = _fake(sc.EXACT)
    # A deficit equal to the counted events passes; one more lost sample does not.
    assert runner.judge(exact, sc.Outcome(0.75, tolerance=1e-12, allowance=0.25), z)["passed"]
    assert not runner.judge(exact, sc.Outcome(0.75, tolerance=1e-12, allowance=0.2), z)["passed"]
    assert not runner.judge(exact, sc.Outcome(1.0, tolerance=1e-12, nan_count=1), z)["passed"]
    stat = _fake(sc.STATISTICAL)
    assert runner.judge(stat, sc.Outcome(1.029, se=0.01), z)["passed"]
    assert not runner.judge(stat, sc.Outcome(1.031, se=0.01), z)["passed"]
    assert not runner.judge(stat, sc.Outcome(0.5, se=0.0), z)["passed"]
    assert not runner.judge(stat, sc.Outcome(math.nan, se=0.01), z)["passed"]
    at_most = _fake(sc.AT_MOST, 10.0)
    assert runner.judge(at_most, sc.Outcome(12.0, allowance=2.0), z)["passed"]
    assert not runner.judge(at_most, sc.Outcome(12.5, allowance=2.0), z)["passed"]
    known = _fake(sc.STATISTICAL, expected_failure="why")
    row = runner.judge(known, sc.Outcome(2.0, se=0.01), z)
    assert row["status"] == "expected failure" and row["passed"]
    row = runner.judge(known, sc.Outcome(1.0, se=0.01), z)     # a fix must update the table
    assert row["status"] == "unexpected pass" and not row["passed"]
    assert runner.judge(_fake(sc.UNSUPPORTED), None, z)["status"] == "not supported"


def test_z_critical_is_sidak():
    assert runner.z_critical(1) == pytest.approx(2.5758, abs=1e-4)
    assert runner.z_critical(20) > runner.z_critical(10) > runner.z_critical(1)


# ---------------------------------------------------------------------------------------------
# Power: wrong answers and wrong renders fail


@pytest.mark.parametrize("case_id", ["slab 1e-05 thick at 0 deg, max depth 100",
                                     "CoC focus 1 f/2.8 6-blade polygon",
                                     "point lamp out of focus, focus 1 f/2.8"])
def test_statistical_case_fails_with_analytic_value_off_by_its_bound(case_id):
    case = _case(case_id)
    good = _run([case])
    bound = good["cases"][0]["bound"]
    assert good["passed"], good["cases"][0]
    off = dataclasses.replace(case, analytic=case.analytic + 2.5 * bound)
    assert not _run([off])["passed"]


def test_exact_case_fails_with_analytic_value_off_by_float_rounding():
    case = _case("furnace glass sphere smooth scale 1 offset 0 ior 1.5")
    assert _run([case])["passed"]
    assert not _run([dataclasses.replace(case, analytic=1.0 + 1e-9)])["passed"]


@pytest.fixture
def scaled_render(monkeypatch):
    """Every render comes back 1% too bright (its sums and sums of squares scaled)."""
    original = integrator.Renderer.render

    def render(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        result.sum *= 1.01
        result.sum_sq *= 1.01 ** 2
        return result
    monkeypatch.setattr(integrator.Renderer, "render", render)


@pytest.mark.parametrize("case_id", ["furnace glass sphere smooth scale 1 offset 0 ior 1.5",
                                     "slab 0.001 thick at 0 deg, max depth 2",
                                     "open glass mesh (one quad; exporter warns 'not closed')",
                                     "zero-size point lamp over a floor"])
def test_a_one_percent_brighter_render_fails(scaled_render, case_id):
    assert not _run([_case(case_id)])["passed"]


def test_a_ten_percent_larger_aperture_fails(monkeypatch):
    from snell.tracer import camera
    original = camera.aperture_radius
    monkeypatch.setattr(camera, "aperture_radius", lambda cam: 1.1 * original(cam))
    for case_id in ("CoC focus 0.001 f/0.5 disk", "CoC focus 1e+06 f/1e+06 disk",
                    "point lamp out of focus, focus 1 f/2.8"):
        assert not _run([_case(case_id)])["passed"], case_id


def test_a_lost_sample_fails_the_furnace(monkeypatch):
    """One sample of one pixel missing, the integrator counting nothing: the furnace sees it."""
    original = integrator.Renderer.render

    def render(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        result.sum[0, 0] -= 1.0
        return result
    monkeypatch.setattr(integrator.Renderer, "render", render)
    assert not _run([_case("camera inside a glass ball (at its centre)")])["passed"]


def test_memory_bound_counts_the_accumulation_buffers():
    assert extremes.working_set_bytes(2, 1024 * 1024) < 2 * 1024 * 1024 * 3 * 8   # smaller than the sums
    # A pass's jobs grow with the image (a Future per chunk), 0.25 byte per pixel against 48.
    grows = extremes.working_set_bytes(2, 8192 * 8192) - extremes.working_set_bytes(2, 1024 * 1024)
    assert grows < 0.01 * 2 * 8192 * 8192 * 3 * 8


# ---------------------------------------------------------------------------------------------
# The command


def test_quick_suite_passes_and_writes_stable_report(tmp_path, capsys):
    out = tmp_path / "report"
    assert cli.main(["stress", "--quick", "--report", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "all pass" in printed and "analytic" in printed
    data = json.loads((out / "stress.json").read_text())
    assert set(data) == {"version", "quick", "threads", "alpha", "statistical_cases", "z_critical",
                         "rule", "cases", "passed", "failed", "total_s", "worst", "provenance"}
    assert data["passed"] and data["quick"] and data["failed"] == []
    assert len(data["cases"]) >= 25
    groups = {c["group"] for c in data["cases"]}
    assert groups == {"white furnace", "glass slab", "nested and coincident", "thin lens", "lights",
                      "degenerate geometry", "image extremes"}
    for c in data["cases"]:
        assert set(c) == set(runner.CASE_KEYS)
        assert c["failure_means"] and c["measures"]
        assert c["nan_inf"] == 0
        assert c["status"] in ("pass", "expected failure", "not supported"), c
        if c["expected_failure"]:
            assert c["status"] == "expected failure"
    page = (out / "stress.html").read_text()
    assert page.count("data:image/png;base64,") >= 3 and data["worst"] in page


def test_exit_status_1_when_a_case_fails(monkeypatch, tmp_path, capsys):
    broken = dataclasses.replace(_case("two coplanar emissive faces"), analytic=2.0)
    monkeypatch.setattr(runner, "all_cases", lambda quick: [broken])
    assert cli.main(["stress", "--report", str(tmp_path / "r")]) == 1
    printed = capsys.readouterr().out
    assert "FAIL" in printed and "two coplanar emissive faces" in printed
    data = json.loads((tmp_path / "r" / "stress.json").read_text())
    assert data["failed"] == ["two coplanar emissive faces"] and not data["passed"]


def test_a_crashing_case_is_a_failure_not_a_traceback(monkeypatch, capsys):
    def crash(threads, seed):
        raise ValueError("boom")
    monkeypatch.setattr(runner, "all_cases",
                        lambda quick: [dataclasses.replace(_case("two coplanar emissive faces"), run=crash)])
    assert cli.main(["stress"]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_report_directory_must_have_a_parent(capsys):
    assert cli.main(["stress", "--report", "/nonexistent-dir/x"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("snell: error: --report") and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_full_matrix_passes(tmp_path):
    data = runner.run(quick=False, threads=2)
    runner.write_report(str(tmp_path), data)
    assert data["passed"], data["failed"]


def test_poisson_quantile():
    from scipy import stats
    from snell.stress.lens import poisson_quantile
    for mean in (0.0034, 0.5, 3.0, 20.0):
        for alpha in (1e-2, 1e-4):
            assert poisson_quantile(mean, alpha) == stats.poisson.isf(alpha, mean)
