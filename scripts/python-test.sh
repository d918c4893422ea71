#!/usr/bin/env bash
# Builds the Python package (python/, maturin + pyo3) into a virtual environment and runs its
# pytest suite (python/tests): shapes and autoreset, errors, the same numbers as the CLI's
# rollout (needs target/release/fluxswarm-gpu, which `cargo test --release` builds, or
# FLUXSWARM_BIN), PettingZoo's API and seed tests, MOMAland's API test, the examples and the
# overhead benchmark (a few steps). Needs python3 with venv and pip, and PyPI (maturin,
# numpy, gymnasium, pettingzoo, momaland, pytest); an offline machine skips this with
# FLUXSWARM_SKIP_PYTHON=1. The environment lives in target/python-venv (PYTHON_VENV to move it).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${PYTHON_VENV:-target/python-venv}
if ! python3 -c "import venv, ensurepip" 2>/dev/null; then
    echo "== installing python3-venv (python3 has no venv/ensurepip)"
    sudo_=""
    [ "$(id -u)" = 0 ] || sudo_=sudo
    $sudo_ apt-get install -y -qq python3-venv >/dev/null
fi
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q "./python[test]"
# From outside python/, so that `import fluxswarm` is the installed package, not the sources.
export FLUXSWARM_BIN="${FLUXSWARM_BIN:-$PWD/target/release/fluxswarm-gpu}"
(cd "$venv" && bin/python -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests")
