#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: lints (cargo fmt, clippy with warnings as errors, with and without the Python
# bindings), the Rust suite (cargo test) and the Python suite (pytest).
# Each stage's wall time is printed as it ends ("test.sh: N s: COMMAND").
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
stage() {
    local start=$SECONDS
    "$@"
    echo "test.sh: $((SECONDS - start)) s: $*"
}
stage "$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
stage "$PYTHON" -m pip install --quiet -e ".[test]"
stage cargo fmt --check
stage cargo clippy --release --all-targets -- -D warnings
stage cargo clippy --release --lib --features python -- -D warnings
stage cargo test --release
stage "$PYTHON" -m pytest -q
