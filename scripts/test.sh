#!/usr/bin/env bash
# Sets up, builds everything (warnings are errors; an earlier demo build is reused) and runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
# The browser tests' packages, exactly as locked (puppeteer-core; no browser download: they use Debian's Chromium).
(cd tests/browser && npm ci --no-audit --no-fund)
cd build
ctest --output-on-failure --timeout 600 -j "$(nproc)"
