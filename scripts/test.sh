#!/usr/bin/env bash
# Sets up, builds everything (warnings are errors; an earlier demo build is reused) and runs every test through ctest,
# the sanitizer run among them: the readers and decoders built again with ASan and UBSan (VOXBRICK_SANITIZE; label
# asan, tests/sanitize).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DVOXBRICK_SANITIZE=ON > /dev/null
bash scripts/build.sh
# The browser tests' packages, exactly as locked (puppeteer-core; no browser download: they use Debian's Chromium).
(cd tests/browser && npm ci --no-audit --no-fund)
cd build
ctest --output-on-failure --timeout 600 -j "$(nproc)"
