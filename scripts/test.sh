#!/usr/bin/env bash
# Installs what the tests need (Python deps, the extension built in release mode) and runs
# every test: lints (cargo fmt, clippy with warnings as errors, the Python bindings
# included), the Rust suite (cargo test) and the Python suite (pytest).
# Each stage's wall time is printed as it ends ("test.sh: N s: COMMAND").
#
# The Rust checks (cargo fmt, the lints, cargo test) run while pip builds the extension, in a
# target directory of their own (TARGET/rust): cargo locks a target directory for the whole
# of a build, and cargo test would compile most of its dependencies again after pip's build
# anyway: the bindings' dependencies (pyo3, numpy) and cargo test's dev-dependencies
# (criterion) turn on different features of common crates (num-traits, either, syn, ...),
# which changes the hash of every crate above them, faer and nalgebra included; what the
# Rust checks share (build scripts, proc-macros) they share among themselves. pip's build of
# the crate itself runs on one core (codegen-units = 1) and would leave the other idle.
# One clippy pass with the bindings' feature lints the crate with its Python side, the tests
# and the benchmarks (a check links nothing; two passes took 206 s against 156 s); cargo
# test builds the crate without the bindings, its warnings errors too. (Building the tests
# in 16 codegen units instead of one was slower here, 318 s against 258 s: beside pip's
# build, both cores are busy anyway, and more units do more work.)
# pytest runs after both, on two workers (pytest-xdist): its tests run Python, mostly on one
# core each (measured on 2 cores: 215 s against 290 s on one worker); started beside the
# Rust checks' tail instead, both slowed and the whole took longer (735 s against 672 s).
# The tests that time how fast a run hears Ctrl-C (marked `timed`) run last, alone.
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
rust() {
    stage cargo fmt --check
    stage cargo clippy --release --all-targets --features python -- -D warnings
    RUSTFLAGS="-D warnings" stage cargo test --release
}
stage "$PYTHON" -m pip install --quiet --upgrade "pip>=23" "maturin>=1.9.4,<2"
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target}/rust" rust &
rust_pid=$!
installed=0
stage "$PYTHON" -m pip install --quiet -e ".[test]" || installed=$?
start=$SECONDS checked=0
wait "$rust_pid" || checked=$?
echo "test.sh: $((SECONDS - start)) s: waiting for the Rust checks after the install"
if ((installed || checked)); then
    exit 1
fi
stage "$PYTHON" -m pytest -q -n 2 -m "not timed"
stage "$PYTHON" -m pytest -q -m timed
