#!/usr/bin/env bash
# The Python package's CI, run after `cargo test --workspace` (which built target/debug/lumen):
# a venv in target/py-venv, the package built in the dev profile (reusing cargo's build) and
# installed, then its pytest tests against that daemon binary. Exits non-zero on any failure.
#
# Env: PYTHON (default python3), CARGO_TARGET_DIR (default <repo>/target), LUMEN_BIN (default
# $CARGO_TARGET_DIR/debug/lumen).
set -euo pipefail
cd "$(dirname "$0")/../.."
repo=$(pwd)
target=${CARGO_TARGET_DIR:-$repo/target}
venv=$target/py-venv
python=${PYTHON:-python3}
export LUMEN_BIN=${LUMEN_BIN:-$target/debug/lumen}
if [ ! -x "$LUMEN_BIN" ]; then
    echo "ci.sh: $LUMEN_BIN is missing: run \`cargo build -p lumen-cli --bin lumen\` (or \`cargo test --workspace\`) first" >&2
    exit 1
fi
if [ ! -x "$venv/bin/python" ]; then
    echo "ci.sh: creating $venv"
    "$python" -m venv "$venv"
fi
# The venv's tools first on PATH: maturin's build backend runs the `maturin` executable by name.
export PATH="$venv/bin:$PATH"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "maturin>=1.9.4,<2" numpy pytest zstandard
# matplotlib is only for the example; its absence is not a failure.
"$venv/bin/python" -m pip install --quiet matplotlib || echo "ci.sh: matplotlib not installed (only examples/insertion.py needs it)"
echo "ci.sh: building and installing lumen (dev profile)"
# maturin builds the wheel with cargo in the dev profile (into $target, reusing the workspace's
# build), and pip installs it; no build isolation: maturin is in the venv already.
MATURIN_PEP517_ARGS="--profile dev" "$venv/bin/python" -m pip install --quiet --no-build-isolation --force-reinstall --no-deps ./client/python
echo "ci.sh: pytest (LUMEN_BIN=$LUMEN_BIN)"
"$venv/bin/python" -m pytest client/python/tests -q
