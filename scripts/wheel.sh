#!/usr/bin/env bash
# Builds flextop's abi3 manylinux wheel with maturin, installs it in a fresh virtualenv
# whose PATH has no Rust toolchain, and runs the demo there: what `pip install flextop`
# gives a user without Rust. Prints the wheel's path, its manylinux tag and the demo's
# output. About 3 minutes on 2 cores (a release build); a documented benchmark step, not
# part of CI (BENCHMARKS.md, "Wheels").
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"$PYTHON" -m pip install --quiet "maturin>=1.9.4,<2" ziglang
# manylinux_2_28: glibc 2.28 or newer (RHEL 8, Debian 10, Ubuntu 18.10 and later). Zig
# links against that glibc whatever the build machine's, and maturin checks the symbols
# the extension uses against the policy.
"$PYTHON" -m maturin build --release --zig --compatibility manylinux_2_28 --out "$out/dist"
wheel="$(ls "$out"/dist/flextop-*.whl)"
echo "built $(basename "$wheel")"
"$PYTHON" -m venv "$out/venv"
# a PATH without cargo or rustc: only the venv and the system's basic tools
env -i HOME="$HOME" PATH="$out/venv/bin:/usr/bin:/bin" bash -c '
    set -euo pipefail
    if command -v cargo >/dev/null || command -v rustc >/dev/null; then echo "a Rust toolchain is on PATH"; exit 1; fi
    pip install --quiet "$1"
    cd "$2" && flextop demo --out demo_out
    python -c "import flextop, sys; print(\"flextop\", flextop.__version__, \"from\", flextop.__file__, \"on Python\", sys.version.split()[0])"
' _ "$wheel" "$out"
