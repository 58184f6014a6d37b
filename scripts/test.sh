#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: the Rust suite (cargo test) and the Python suite (pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
"$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
"$PYTHON" -m pip install --quiet -e ".[test]"
cargo test --release
"$PYTHON" -m pytest -q
