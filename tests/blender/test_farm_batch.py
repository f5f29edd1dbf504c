"""`snell batch --workers` (farm/render.py's Session, addon/batch.py): each frame to come is
started on the cluster before the one under way, at a lower Dask priority, so that its windows
fill the workers the last frame's tail leaves idle; the images stay the local ones bit for bit.
The batch runs in this process (cli.main), so that the farm's calls can be watched."""
import os
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
pytest.importorskip("distributed")

from snell import cli  # noqa: E402
from snell.farm import render as render_module  # noqa: E402
from snell.tracer import image  # noqa: E402
from support.windows import sample_windows  # noqa: E402

# 32x32 at 8 spp in windows of 2 samples (the client's sample_windows, below: a
# worker traces the window it is given), four per frame.
ARGS = ("--frames", "1-3", "--spp", "8", "--noise-threshold", "0", "--film-transparent")


def test_batch_starts_each_frame_before_the_last_ends(blender_scenes, tmp_path, monkeypatch):
    """Three frames of a moving camera on two workers: every frame's render finds its first
    windows already submitted (prefetched during the frame before), earlier frames' tasks go
    first (priorities -1, -2, -3), and each EXR (R, G, B, A, samples) is the local one bit for
    bit. Deliberate error caught: the frame to come exported without moving to it (the
    current frame's camera): its started windows are another scene's, none of frames 2 and 3
    finds them ([True, False, False])."""
    sample_windows(monkeypatch, 32 * 32, 2)
    seen = []
    real = render_module.render_frame

    def watched(client, scene, settings, name, frame=0, progress=None, threads=None,
                started=None, priority=0, stop=None):
        seen.append((frame, started is not None and bool(started.futures), priority))
        return real(client, scene, settings, name, frame, progress, threads, started, priority,
                    stop)
    monkeypatch.setattr(render_module, "render_frame", watched)
    blend = str(blender_scenes / "animated.blend")
    assert cli.main(["batch", blend, *ARGS, "-o", str(tmp_path / "local_####.exr")]) == 0
    assert cli.main(["batch", blend, *ARGS, "-o", str(tmp_path / "farm_####.exr"),
                     "--workers", "2"]) == 0
    assert [frame for frame, _, _ in seen] == [1, 2, 3]
    assert [found for _, found, _ in seen] == [True, True, True]
    assert [priority for _, _, priority in seen] == [-1, -2, -3]
    for frame in (1, 2, 3):
        local, farm = (str(tmp_path / f"{name}_{frame:04d}.exr") for name in ("local", "farm"))
        for channel in ("R", "G", "B", "A", "samples"):
            assert np.array_equal(image.read_channel(local, channel),
                                  image.read_channel(farm, channel)), (frame, channel)
    assert not np.array_equal(image.read_exr(str(tmp_path / "farm_0001.exr")),
                              image.read_exr(str(tmp_path / "farm_0002.exr")))


def test_batch_without_dask_is_one_error_before_any_frame(blender_scenes, tmp_path,
                                                          monkeypatch, capsys):
    """`snell batch --workers 2` without Dask: the CliError raised in the opening's thread
    (farm/render.py's Opening, opened while the file opens) ends the batch before its first
    frame, as it did when the cluster opened first: one error line, no frame, nothing written.
    Deliberate error caught: addon/batch.py not waiting for the opening: each frame's render
    meets the error ("3 of 3 frames failed (Snell: --workers and --cluster need Dask ...)")."""
    monkeypatch.setitem(sys.modules, "distributed", None)      # import distributed fails
    blend = str(blender_scenes / "animated.blend")
    status = cli.main(["batch", blend, *ARGS, "-o", str(tmp_path / "farm_####.exr"),
                       "--workers", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and err[-1] == ("snell: error: --workers and --cluster need Dask "
                                       "(pip install 'snell[distributed]')"), err
    assert not any(line.startswith("snell: frame") for line in err), err
    assert os.listdir(tmp_path) == []
