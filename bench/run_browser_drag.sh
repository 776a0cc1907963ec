#!/usr/bin/env bash
# The camera drag in the browser (headless Chromium, the viewer page) beside the same drag through the TCP client, on
# the MRI template: one tab at 512² and 1024², then 16 tabs beside 64 TCP clients, all against one server.
# Results: bench/results/browser/browser-drag.{csv,md,json}. Needs build/voxbrick, Chromium and tests/browser's packages
# (scripts/setup.sh, then `npm ci` in tests/browser). Options after the script's name go to bench/browser_drag.mjs
# (e.g. --sizes 128 --duration 2 --tabs 2 --clients 4 --out bench/work/browser-smoke for a quick check).
set -euo pipefail
cd "$(dirname "$0")/.."
work=bench/work/browser-drag
source bench/browser_bench.sh
browser_bench_setup "$work" run_browser_drag.sh "$@"
node bench/browser_drag.mjs --datasets "$work/datasets" --dataset mri --tf mri --out bench/results/browser/browser-drag "$@"
