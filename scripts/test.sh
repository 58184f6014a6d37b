#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: lints (cargo fmt, clippy with warnings as errors, with and without the Python
# bindings), the Rust suite (cargo test) and the Python suite (pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
"$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
"$PYTHON" -m pip install --quiet -e ".[test]"
cargo fmt --check
cargo clippy --release --all-targets -- -D warnings
cargo clippy --release --lib --features python -- -D warnings
cargo test --release
"$PYTHON" -m pytest -q
