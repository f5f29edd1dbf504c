"""Render the Cycles references the tests use and store them in tests/references/.

    .venv/bin/python tools/make_cycles_references.py [--rewrite] [pytest arguments]

Runs the tests (default: tests/validation, as the default suite runs them) with
SNELL_CYCLES_REFERENCES=update: every tests/support/cycles_reference.Reference loads its stored
file, or renders Cycles and writes tests/references/<key>.npz when there is none (--rewrite:
SNELL_CYCLES_REFERENCES=write, render and rewrite every file). The key hashes what Cycles
renders: the Blender version, the exported scene (not its Snell-only render settings), the
.blend's Cycles-only settings and the Cycles settings; a change to any of them gets a new key.

Every Reference records its key (SNELL_CYCLES_REFERENCES_LOG); files no test used are listed,
and removed when the run was the default one and passed (with pytest arguments the run may not
reach every test, so they are only listed). Mitsuba 3's test_renders.py pattern.
"""
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCES = os.path.join(ROOT, "tests", "references")


# A stored Cycles reference is <key>.npz, the key 20 hex digits; other files there (images.npz,
# test_image_regression's Snell images) are not this tool's to remove.
KEY_FILE = re.compile(r"^[0-9a-f]{20}\.npz$")


def stored():
    if not os.path.isdir(REFERENCES):
        return set()
    return {f[:-4] for f in os.listdir(REFERENCES) if KEY_FILE.match(f)}


def main(argv):
    rewrite = "--rewrite" in argv
    args = [a for a in argv if a != "--rewrite"]
    default = not args
    before = stored()
    with tempfile.NamedTemporaryFile("r", suffix=".keys") as log:
        env = dict(os.environ, SNELL_CYCLES_REFERENCES="write" if rewrite else "update",
                   SNELL_CYCLES_REFERENCES_LOG=log.name)
        args = args or [os.path.join("tests", "validation")]
        status = subprocess.call([sys.executable, "-m", "pytest", "-q", *args], cwd=ROOT, env=env)
        used = set(log.read().split())
    after = stored()
    unused = sorted(after - used)
    size = sum(os.path.getsize(os.path.join(REFERENCES, f"{k}.npz")) for k in after)
    print(f"make_cycles_references: {len(used)} reference(s) used, {len(after - before)} new; "
          f"{len(after)} file(s) in tests/references, {size / 1e6:.2f} MB")
    if unused:
        remove = default and status == 0
        print(("removed" if remove else "not used by this run (kept; the default run removes "
               "them)") + ": " + ", ".join(f"{k}.npz" for k in unused))
        if remove:
            for k in unused:
                os.remove(os.path.join(REFERENCES, f"{k}.npz"))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
