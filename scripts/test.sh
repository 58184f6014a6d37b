#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: lints (cargo fmt, clippy with warnings as errors, with and without the Python
# bindings), the Rust suite (cargo test) and the Python suite (pytest).
# Each stage's wall time is printed as it ends ("test.sh: N s: COMMAND").
#
# The lints run while pip builds the extension. They only check (no code is generated, so
# they share no artifact with a build) and do so in a target directory of their own
# (TARGET/lints), since cargo locks a target directory for the whole of a build: pip's
# build of the crate itself runs on one core (codegen-units = 1) and leaves the other idle.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
stage() {
    local start=$SECONDS status=0
    "$@" || status=$?
    if ((status)); then
        echo "test.sh: failed (exit $status) after $((SECONDS - start)) s: $*"
    else
        echo "test.sh: $((SECONDS - start)) s: $*"
    fi
    return "$status"
}
lints() {
    stage cargo fmt --check
    stage cargo clippy --release --all-targets -- -D warnings
    stage cargo clippy --release --lib --features python -- -D warnings
}
stage "$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target}/lints" lints &
lints_pid=$!
installed=0
stage "$PYTHON" -m pip install --quiet -e ".[test]" || installed=$?
start=$SECONDS linted=0
wait "$lints_pid" || linted=$?
echo "test.sh: $((SECONDS - start)) s: waiting for the lints after the install"
if ((installed || linted)); then
    exit 1
fi
stage cargo test --release
stage "$PYTHON" -m pytest -q
