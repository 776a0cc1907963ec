#!/usr/bin/env bash
# Prints one SHA-256 line per file of a store directory (sorted by path), to show that two preps wrote the same
# store. OpenVDB stamps every file it writes with a random UUID (36 ASCII characters at byte 21 of the header), so
# for vdb/*.vdb that field is zeroed before hashing; every other byte counts.
# Usage: bash bench/store_digest.sh STORE > digest.txt
set -euo pipefail
store=${1:?usage: store_digest.sh STORE}
cd "$store"
find . -type f | LC_ALL=C sort | while read -r f; do
  case "$f" in
    *.vdb)
      sum=$({ head -c 21 "$f"; head -c 36 /dev/zero; tail -c +58 "$f"; } | sha256sum | cut -d' ' -f1)
      echo "$sum  $f (uuid masked)" ;;
    *) sha256sum "$f" ;;
  esac
done
