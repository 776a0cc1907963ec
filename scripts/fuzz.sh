#!/usr/bin/env bash
# Fuzzes the protocol decoder: builds proto/fuzz/fuzz_decode with clang (libFuzzer, ASan, UBSan) in build-fuzz/ and
# runs it for SECONDS (default 60) over build-fuzz/corpus, a copy of the committed seeds that keeps what earlier runs
# found. A crash leaves its input in build-fuzz/artifacts/ and makes this script fail.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
bash scripts/setup.sh
if ! command -v clang++ >/dev/null; then
  # Debian's clang brings libFuzzer and the sanitizer runtimes (libclang-common-14-dev).
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends clang
fi
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DVOXBRICK_FUZZ=ON -DVOXBRICK_WERROR=ON -DVOXBRICK_BUILD_TESTS=OFF \
  -DVOXBRICK_BUILD_BENCH=OFF >/dev/null
cmake --build build-fuzz --target fuzz_decode
mkdir -p build-fuzz/corpus build-fuzz/artifacts
cp -n proto/fuzz/corpus/* build-fuzz/corpus/
build-fuzz/proto/fuzz/fuzz_decode build-fuzz/corpus -max_total_time="$seconds" -max_len=4096 \
  -artifact_prefix=build-fuzz/artifacts/ -print_final_stats=1
