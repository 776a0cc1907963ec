#!/usr/bin/env bash
# A 512² drag over TLS beside the same drag in the clear (bench/tls_drag.mjs): one Chromium tab over ws:// and wss://,
# one `voxbrick load --drag` client over TCP and TLS, on the MRI template, in alternating rounds.
# Results: bench/results/server/tls-drag.{csv,md,json}. Needs build/voxbrick, Chromium, openssl and tests/browser's
# packages (scripts/setup.sh, then `npm ci` in tests/browser). Options after the script's name go to tls_drag.mjs
# (e.g. --duration 2 --rounds 1 --out bench/work/tls-smoke for a quick check).
set -euo pipefail
cd "$(dirname "$0")/.."
work=bench/work/browser-drag
source bench/browser_bench.sh
browser_bench_setup "$work" run_tls_drag.sh "$@"
node bench/tls_drag.mjs --datasets "$work/datasets" --dataset mri --tf mri --out bench/results/server/tls-drag "$@"
