"""Render the Cycles references the validation tests use and store them in tests/references/.

    .venv/bin/python tools/make_cycles_references.py [pytest arguments, default tests/validation]

Runs the tests with SNELL_CYCLES_REFERENCES=write: every tests/support/cycles_reference.Reference
renders Cycles as it would without a stored file, then writes tests/references/<key>.npz (its
per-seed images, seeds, times and settings; the key hashes the Blender version, the exported
scene and the Cycles settings). Later runs load those files instead of rendering Cycles, as long
as bpy.app.version and the scenes are unchanged (a changed scene or setting gets a new key and
renders Cycles again; rerun this, and delete the old file). Mitsuba 3's test_renders.py pattern.
"""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCES = os.path.join(ROOT, "tests", "references")


def main(argv):
    before = set(os.listdir(REFERENCES)) if os.path.isdir(REFERENCES) else set()
    env = dict(os.environ, SNELL_CYCLES_REFERENCES="write")
    args = argv or [os.path.join("tests", "validation")]
    status = subprocess.call([sys.executable, "-m", "pytest", "-q", *args], cwd=ROOT, env=env)
    after = set(os.listdir(REFERENCES)) if os.path.isdir(REFERENCES) else set()
    print(f"make_cycles_references: {len(after)} file(s) in tests/references, {len(after - before)} new")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
