"""Atomic writes of files and report directories: whole or not at all."""
import os

import pytest

from snell.tracer.atomic import atomic_directory, atomic_path


def _write(path, text):
    with open(path, "w") as f:
        f.write(text)


def test_new_report_directory_appears_whole(tmp_path):
    report = tmp_path / "report"
    with atomic_directory(report) as tmp:
        _write(os.path.join(tmp, "report.html"), "page")
        _write(os.path.join(tmp, "metrics.json"), "{}")
        assert not report.exists()          # nothing visible until the end
    assert sorted(os.listdir(report)) == ["metrics.json", "report.html"]
    assert os.listdir(tmp_path) == ["report"]   # no temporary left


def test_existing_report_directory_gets_the_new_files(tmp_path):
    report = tmp_path / "report"
    report.mkdir()
    _write(report / "report.html", "old page")
    _write(report / "notes.txt", "the user's")
    with atomic_directory(report) as tmp:
        _write(os.path.join(tmp, "report.html"), "new page")
    assert (report / "report.html").read_text() == "new page"
    assert (report / "notes.txt").read_text() == "the user's"
    assert os.listdir(tmp_path) == ["report"]


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_failure_leaves_nothing(tmp_path, error):
    report = tmp_path / "report"
    report.mkdir()
    _write(report / "report.html", "old page")
    with pytest.raises(error):
        with atomic_directory(report) as tmp:
            _write(os.path.join(tmp, "report.html"), "half a pa")
            raise error
    assert os.listdir(tmp_path) == ["report"]
    assert (report / "report.html").read_text() == "old page"
    with pytest.raises(error):
        with atomic_path(tmp_path / "a.exr") as tmp:
            _write(tmp, "half an ima")
            raise error
    assert os.listdir(tmp_path) == ["report"]


def test_report_path_that_is_a_file(tmp_path):
    _write(tmp_path / "report", "x")
    with pytest.raises(OSError, match="is a file"):
        with atomic_directory(tmp_path / "report"):
            pass
    assert os.listdir(tmp_path) == ["report"]
