#!/usr/bin/env bash
# Sets up, builds (warnings are errors) and runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh -DVOXBRICK_WERROR=ON
cd build
ctest --output-on-failure --timeout 600 -j "$(nproc)"
