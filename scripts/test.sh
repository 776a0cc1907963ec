#!/usr/bin/env bash
# Sets up, builds everything the tests run (warnings are errors; an earlier demo build is reused; the benchmark tools
# no test runs are left to `cmake --build build --target benches`) and runs every test through ctest, the sanitizer
# run among them: the readers and decoders built again with ASan and UBSan (VOXBRICK_SANITIZE; label asan,
# tests/sanitize).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DVOXBRICK_SANITIZE=ON -DVOXBRICK_ALL_BENCH_IN_ALL=OFF > /dev/null
bash scripts/build.sh
# The browser tests' packages, exactly as locked (puppeteer-core; no browser download: they use Debian's Chromium).
(cd tests/browser && npm ci --no-audit --no-fund)
cd build
status=0
ctest --output-on-failure --timeout 600 -j "$(nproc)" || status=$?
if [ "$status" -ne 0 ]; then
  # A long log is read from its end: each failed test's last lines once more, after ctest's summary.
  echo "=== the failed tests' last lines (the whole output is above, and in build/Testing/Temporary/LastTest.log)"
  while IFS=: read -r _ name; do
    echo "--- $name"
    awk -v name="$name" '
      index($0, " Test: ") && substr($0, index($0, " Test: ") + 7) == name { inside = 1; n = 0; next }
      inside == 1 && /^Output:$/ { inside = 2; getline; next }
      inside == 2 && /^<end of output>$/ { inside = 0 }
      inside == 2 { line[n++ % 25] = $0 }
      END { for (i = (n > 25 ? n - 25 : 0); i < n; ++i) print "  " line[i % 25] }
    ' Testing/Temporary/LastTest.log
  done < <(cat Testing/Temporary/LastTestsFailed.log 2> /dev/null)
  exit "$status"
fi
