"""Stored Cycles references (tests/support/cycles_reference.py): a file read back gives the
CyclesResult that was written, and a file from another Blender version is not used."""
import numpy as np

from snell.validation.cycles import CyclesResult
from support import cycles_reference as cr


def _result(rng):
    images = [rng.random((4, 6, 3)).astype(np.float32).astype(np.float64) for _ in range(8)]
    stack = np.stack(images)
    return CyclesResult(stack.mean(0), stack.var(0, ddof=1) / len(stack), 64, list(range(1, 9)), 1.5,
                        [("cycles.samples", 8, "per seed")], images)


def test_a_stored_reference_reads_back_as_rendered(tmp_path, monkeypatch):
    monkeypatch.setattr(cr, "blender_version", lambda: [5, 0, 1])
    cyc = _result(np.random.default_rng(0))
    path = str(tmp_path / "references" / "key.npz")
    cr.save_cycles(path, cyc)
    back = cr.load_cycles(path)
    assert np.array_equal(back.mean, cyc.mean) and np.array_equal(back.variance_of_mean, cyc.variance_of_mean)
    assert all(np.array_equal(a, b) for a, b in zip(back.images, cyc.images))
    assert (back.spp, back.seeds, back.time_s, back.settings) == (cyc.spp, cyc.seeds, cyc.time_s, cyc.settings)


def test_a_reference_from_another_blender_is_not_used(tmp_path, monkeypatch):
    monkeypatch.setattr(cr, "blender_version", lambda: [5, 0, 1])
    path = str(tmp_path / "key.npz")
    cr.save_cycles(path, _result(np.random.default_rng(1)))
    monkeypatch.setattr(cr, "blender_version", lambda: [5, 1, 0])
    assert cr.load_cycles(path) is None
    assert cr.load_cycles(str(tmp_path / "missing.npz")) is None
