#!/usr/bin/env bash
# Set up a development checkout from scratch and make a first render:
#   .venv (Python 3.11) -> pip install -e '.[dev]' -> scenes/*.blend -> out/cornell_spheres.{exr,png}
# Safe to run again: every step reuses what is already there.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

if [ ! -x .venv/bin/python ]; then
    echo "bootstrap: creating .venv with python3.11"
    python3.11 -m venv .venv
fi

# Headless Chromium for the report test (tests/validation/test_compare.py); Debian's package, if apt is usable.
if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    echo "bootstrap: apt-get install chromium"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq || true
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium \
        || echo "bootstrap: chromium could not be installed: the report test will skip" >&2
fi

echo "bootstrap: pip install -e '.[dev]'"
.venv/bin/python -m pip install --quiet -e '.[dev]'

if [ -f scenes/build_all.py ]; then
    echo "bootstrap: building the reference scenes"
    .venv/bin/python scenes/build_all.py
    mkdir -p out
    echo "bootstrap: rendering scenes/cornell_spheres.blend at 64 spp"
    .venv/bin/snell render scenes/cornell_spheres.blend \
        -o out/cornell_spheres.exr --png out/cornell_spheres.png --spp 64
else
    echo "bootstrap: scenes/build_all.py not found: skipping the reference scenes and the first render" >&2
fi
