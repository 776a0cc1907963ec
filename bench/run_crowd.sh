#!/usr/bin/env bash
# A crowd on one server (bench/crowd.mjs): 16 viewer tabs dragging in headless Chromium beside 64 dragging TCP clients
# (A), beside 64 clients asking 1024² still frames as fast as they can (B), and the same with --batch (B'), on the MRI
# template, judged against the fair scheduler's targets; with --baseline-exe PATH each scenario runs on that binary's
# server too, side by side in the same run. Results: bench/results/crowd/crowd.{csv,md,json}. Needs build/voxbrick,
# Chromium and tests/browser's packages (scripts/setup.sh, then `npm ci` in tests/browser). Options after the script's
# name go to bench/crowd.mjs; a smoke check:
#   bash bench/run_crowd.sh --tabs 2 --drag-clients 4 --batch-clients 4 --duration 3 --size 128 --batch-size 256 \
#     --out bench/work/crowd-smoke
set -euo pipefail
cd "$(dirname "$0")/.."
work=bench/work/crowd
source bench/browser_bench.sh
browser_bench_setup "$work" run_crowd.sh "$@"
node bench/crowd.mjs --datasets "$work/datasets" --dataset mri --tf mri --out bench/results/crowd/crowd "$@"
