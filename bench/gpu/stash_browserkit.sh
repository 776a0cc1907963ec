#!/usr/bin/env bash
# On the GPU machine, in the calls before the measuring one: keeps the browser kit's parts this call carried
# (bench/gpu/browserkit/part-N and SHA256SUMS) in /tmp/voxbrick-browserkit-parts, where measure.sh finds them while
# the machine stays warm, checks each against SHA256SUMS, and says which parts are still to come.
#
#   bash bench/gpu/stash_browserkit.sh [--from bench/gpu/browserkit]
set -euo pipefail
cd "$(dirname "$0")/../.."
from=bench/gpu/browserkit
[ "${1:-}" = --from ] && from=$2
stash=/tmp/voxbrick-browserkit-parts
die() { echo "stash_browserkit.sh: $*" >&2; exit 1; }
[ -f "$from/SHA256SUMS" ] || die "no $from/SHA256SUMS: carry it with each part"
mkdir -p "$stash"
# Parts of another pack would not make the archive: start afresh when the sums differ.
cmp -s "$from/SHA256SUMS" "$stash/SHA256SUMS" 2> /dev/null || rm -f "$stash"/part-* "$stash/SHA256SUMS"
cp "$from/SHA256SUMS" "$stash/"
for part in "$from"/part-*; do
  [ -f "$part" ] || continue
  cp "$part" "$stash/"
done
missing=()
while read -r sum name; do
  [[ "$name" == part-* ]] || continue
  if [ ! -f "$stash/$name" ]; then missing+=("$name"); continue; fi
  [ "$(sha256sum < "$stash/$name" | cut -d' ' -f1)" = "$sum" ] || { rm -f "$stash/$name"; die "$name arrived damaged"; }
done < "$from/SHA256SUMS"
echo "stash_browserkit.sh: $stash holds $(ls "$stash" | grep -c '^part-') parts;" \
  "still to come: ${missing[*]:-none}"
