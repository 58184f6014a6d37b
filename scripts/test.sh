#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: lints (cargo fmt, clippy with warnings as errors, the Python bindings
# included), the Rust suite (cargo test) and the Python suite (pytest).
# Each stage's wall time is printed as it ends ("test.sh: N s: COMMAND").
#
# The order is what two cores do best with (measured on a 2-core machine, README):
# - pip builds the extension in release mode (with the maturin just installed: no isolated
#   build environment to make) (the crate itself in four codegen units, Cargo.toml)
#   while the lints run beside it in a target directory of their own (TARGET/clippy; cargo
#   locks a target directory for a whole build): cargo fmt, then one clippy pass with the
#   bindings' and the benchmarks' features over the crate, its tests and the benchmarks,
#   warnings as errors (a check links nothing).
# - cargo test then builds in pip's target directory and reuses the dependencies pip
#   compiled: the test build resolves the features pip's build does (the bindings'
#   dependencies are dev-dependencies; criterion is behind the `bench` feature), and no
#   RUSTFLAGS are set (a crate's features and flags enter the hash of every crate above it).
#   Every Rust test sits in the library's own test binary (src/tests/, no doctests): one
#   compilation of the crate, not a second one for an rlib the tests would link. Warnings
#   are errors here as well: the build's output is searched for them.
# - pytest then runs on two workers (pytest-xdist): its tests run Python, mostly on one core
#   each (215 s against 290 s on one worker). Started beside cargo test instead, both took
#   longer than one after the other (317 s and 271 s against 163 s and 111 s). The tests
#   that time how fast a run hears Ctrl-C (marked `timed`) run last, alone.
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
    stage cargo clippy --release --all-targets --features python,bench -- -D warnings
}
rust_tests() {
    local log="${CARGO_TARGET_DIR:-target}/test-build.log"
    mkdir -p "$(dirname "$log")"
    cargo test --release --no-run 2>&1 | tee "$log"
    if grep -q "^warning" "$log"; then
        echo "cargo test: the build warned (warnings are errors)"
        return 1
    fi
    cargo test --release
}
stage "$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target}/clippy" lints &
lints_pid=$!
stage "$PYTHON" -m pip install --quiet --no-build-isolation -e ".[test]"
start=$SECONDS
wait "$lints_pid"
echo "test.sh: $((SECONDS - start)) s: waiting for the lints after the install"
stage rust_tests
stage "$PYTHON" -m pytest -q -n 2 -m "not timed"
stage "$PYTHON" -m pytest -q -m timed
