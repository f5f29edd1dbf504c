"""tracer/provenance.py: what every report records about the code and the machine that made it."""
import json
import os
import subprocess

import pytest

from snell.tracer import provenance
from support.paths import ROOT


def test_provenance_names_snell_blender_and_the_machine():
    p = provenance.provenance()
    assert p["snell"] == "0.1.0" or p["snell"][0].isdigit()
    assert p["machine"]["cpu_count"] == os.cpu_count() and p["machine"]["arch"]
    assert p["blender"] and p["blender"][0].isdigit()      # the bpy module's metadata
    json.dumps(p)                                         # a report's JSON holds it as it is
    line = provenance.describe(p)
    assert line.startswith(f"Snell {p['snell']}") and f"Blender {p['blender']}" in line


def test_the_version_is_the_manifests_and_pyprojects():
    import tomllib
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        assert tomllib.load(f)["project"]["version"] == provenance.snell_version()


def test_commit_is_the_checkouts_head():
    head = subprocess.run(["git", "-C", ROOT, "rev-parse", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    if not head:
        pytest.skip("not a git checkout")
    assert head.startswith(provenance.snell_commit().removesuffix("+dirty"))


def test_every_report_writer_records_it(tmp_path):
    """The JSON writers of compare/study/false-alarms, bench and stress, and the HTML page frame
    they all share."""
    from snell.pages.html_page import page
    from snell.stress import runner
    from snell.validation import bench_report, report

    report._write_json(str(tmp_path / "a.json"), {"x": 1})
    bench_report.write_json(str(tmp_path / "b.json"), {"x": 1})
    runner.write_json(str(tmp_path / "c.json"), {"x": 1})
    for name in "abc":
        with open(tmp_path / f"{name}.json") as f:
            assert json.load(f)["provenance"] == provenance.provenance()
    assert provenance.describe() in page("t", "<p>body</p>")


def test_the_machine_names_its_processor():
    """Linux's platform.processor() is empty; reports need a name (bench's missing_values)."""
    from snell.tracer import provenance
    name = provenance.machine()["processor"]
    assert isinstance(name, str) and name.strip()
