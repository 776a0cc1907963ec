#!/usr/bin/env bash
# Configures and builds voxbrick into build/ (Release, Ninja, warnings as errors). Arguments name the targets to build
# (default: everything). The demo builds only `voxbrick`; the tests then reuse that build, since the flags agree.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DVOXBRICK_WERROR=ON
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build build --parallel "$(nproc)" "${targets[@]}"
