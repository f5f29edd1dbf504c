"""The caustic scenes of `snell bench --caustic-scenes` (issue 34's bench targets): what each
benches Snell with, what without, which reference it is measured against and how Cycles is set
up for it "as users would"; and their .blend files, built on demand from scenes/*.py into the
bench cache (not by scenes/build_all.py: the image regression renders every built scene).

Cycles as users would set it up: the files switch on its shadow caustics (manifold next-event
estimation: a caustics light, casters and receivers, scenes/common.py shadow_caustics) where a
lamp lights the glass; path guiding (Cycles' CPU path guiding, scene.cycles.use_guiding) where
it helps (GUIDING_MEASURED). The references are Cycles' plain path tracer (shadow caustics
and guiding off: unbiased), or Snell's hybrid where Cycles' path tracer cannot render the
caustic at all (a delta lamp's light through glass: unbiased but where the file's shadow
caustics render that light seen through glass, which only they render).
"""
from __future__ import annotations

import glob
import hashlib
import os
import subprocess
import sys
from dataclasses import asdict, dataclass, field

from . import cycles

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES_DIR = os.path.join(REPO, "scenes")

# Cycles' path guiding (its defaults: 128 training samples, surface guiding) against plain path
# tracing, both with the files' shadow caustics, measured on these scenes (3 seeds each, 128x128
# at 32 spp and 64x64 at 256 spp): it helped on none at equal time (relative variance x time
# 1.06-2.0x higher; on the HDRI scene at 256 spp the variance 0.70x in 1.7x the time), so every
# scene's Cycles renders without it. docs/measurements.md, "Caustic scenes in the bench".
GUIDING_MEASURED = "measured: docs/measurements.md#caustic-scenes-in-the-bench"


@dataclass(frozen=True)
class BenchScene:
    """One caustic scene of the bench: scenes/<name>.py builds it."""
    name: str
    strategy: str                 # the new strategy, in words
    snell: dict                   # Snell's settings with it (over the bench's own)
    without: dict                 # Snell's settings without it
    without_label: str
    reference: str                # "cycles" (plain path tracing) or "snell" (Snell's hybrid)
    why_reference: str
    guiding: bool = False         # Cycles' path guiding on, as a user would where it helps
    biased: bool = False          # the strategy is consistent, not unbiased
    least_ref_seeds: int = 0      # the reference's seeds at least, whatever --ref-seeds asks
    notes: tuple = field(default=())

    def cycles_settings(self) -> list:
        """Cycles' settings beyond the bench's forced ones, as a user renders this scene (the
        file's shadow caustics are kept: the forced settings do not touch them)."""
        return [(cycles.SHADOW_CAUSTICS, True, "as the file sets them (as a user would)"),
                ("cycles.use_guiding", self.guiding,
                 "path guiding " + ("on: it helps here" if self.guiding else
                                    "off: it did not help here") + f" ({GUIDING_MEASURED})")]

    def describe(self) -> dict:
        """The scene's setup for bench.json."""
        return {**asdict(self), "cycles_settings": [list(s) for s in self.cycles_settings()]}


PLAIN_REFERENCE = [(cycles.SHADOW_CAUSTICS, False, "the reference converges: Cycles' shadow "
                    "caustics (MNEE) are biased"),
                   ("cycles.use_guiding", False, "plain path tracing")]

_LIGHT_PATHS = "Snell, caustics off (the path tracer alone)"
_LIGHT_PATHS_MNEE = "Snell, caustics off (the path tracer, and the file's shadow caustics)"
_MNEE_OFF = "Snell, shadow caustics off (path tracer and light tracer)"

CAUSTIC_SCENES = (
    BenchScene("sun_caustic", "light paths from a delta lamp (a sun of angle 0)",
               {"caustics": True}, {"caustics": False}, _LIGHT_PATHS_MNEE, "snell",
               "Snell's hybrid (caustics on, and the file's shadow caustics for the sun's light "
               "onto the floor seen through glass, which no camera or light path renders): no "
               "camera path reaches a sun of angle 0, so Cycles' path tracer renders no "
               "caustic from it, and its shadow caustics clamp their geometry term "
               "(docs/measurements.md, delta lamps)"),
    BenchScene("hdri_caustic", "light paths from the world (an HDRI with a sun)",
               {"caustics": True}, {"caustics": False}, _LIGHT_PATHS, "cycles",
               "Cycles' plain path tracer (unbiased; shadow caustics do not apply to the world)"),
    BenchScene("pool", "manifold next-event estimation (the file's shadow caustics)",
               {"caustics": True, "shadow_caustics": True}, {"caustics": True,
                                                             "shadow_caustics": False},
               _MNEE_OFF, "cycles", "Cycles' plain path tracer (unbiased)"),
    # Cycles' path tracer renders the tube's shadow as speckle: at 16 x 512 spp the
    # reference's own caustic relMSE (0.125) was a floor under both renderers' errors
    # (docs/measurements.md, the tumbler's reference).
    BenchScene("tumbler_caustic", "manifold next-event estimation (the file's shadow caustics)",
               {"caustics": True, "shadow_caustics": True}, {"caustics": True,
                                                             "shadow_caustics": False},
               _MNEE_OFF, "cycles", "Cycles' plain path tracer (unbiased)",
               least_ref_seeds=160),
)


def select(names: str) -> tuple:
    """The caustic scenes named in a comma-separated list ("all": every one), in its order."""
    if names == "all":
        return CAUSTIC_SCENES
    by_name = {s.name: s for s in CAUSTIC_SCENES}
    wanted = [n.strip() for n in names.split(",") if n.strip()]
    unknown = [n for n in wanted if n not in by_name]
    if unknown or not wanted:
        raise ValueError(f"--caustic-scenes {names!r}: expected 'all' or names among "
                         f"{', '.join(by_name)}")
    return tuple(by_name[n] for n in wanted)


def scripts_key() -> str:
    """sha256 (16 hex digits) of every scene script: a changed script builds the files again."""
    h = hashlib.sha256()
    for path in sorted(glob.glob(os.path.join(SCENES_DIR, "*.py"))):
        h.update(os.path.basename(path).encode())
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:16]


def build(cache_dir, log=None, scenes=CAUSTIC_SCENES) -> list:
    """[(path of the .blend, BenchScene)], each built by its script in a child process into
    cache_dir/scenes/<scripts_key>/ unless already there."""
    log = log or (lambda s: None)
    directory = os.path.join(cache_dir, "scenes", scripts_key())
    os.makedirs(directory, exist_ok=True)
    out = []
    for scene in scenes:
        path = os.path.join(directory, f"{scene.name}.blend")
        if not os.path.isfile(path):
            log(f"{scene.name}: building scenes/{scene.name}.py")
            tmp = os.path.join(directory, f".{scene.name}.{os.getpid()}.blend")
            proc = subprocess.run([sys.executable, os.path.join(SCENES_DIR, f"{scene.name}.py"),
                                   tmp], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            if proc.returncode != 0 or not os.path.isfile(tmp):
                tail = proc.stderr.decode(errors="replace").strip().splitlines()[-3:]
                raise RuntimeError(f"scenes/{scene.name}.py exited {proc.returncode}: "
                                   + " / ".join(tail))
            os.replace(tmp, path)
        out.append((path, scene))
    return out
