#!/usr/bin/env bash
# A process's start, side by side: the CPU time (user + system) and wall time of short `voxbrick` commands, for two
# builds run in turn (OLD, NEW, OLD, NEW, ... ROUNDS rounds of RUNS runs each), so that a busy or quiet spell of the
# machine falls on both. The medians of the rounds go to OUT.csv and OUT.md.
#
#   bash bench/startup_ab.sh OLD_VOXBRICK NEW_VOXBRICK [--rounds 3] [--runs 15] [--out bench/results/startup/startup]
#
# OLD_VOXBRICK is another build's binary (e.g. bench/gpu/build_baseline.sh's, bench/work/baseline/bin/voxbrick). The
# commands: --help; info, render (72x64) and prep (--no-vdb) of a 32^3 synthetic store made here by NEW.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n '2,9p' "$0"; exit 2; }
old=$1 new=$2
shift 2
rounds=3 runs=15 out=bench/results/startup/startup
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) echo "startup_ab.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
for exe in "$old" "$new"; do [ -x "$exe" ] || { echo "startup_ab.sh: $exe is not an executable" >&2; exit 1; }; done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$new" prep synthetic:blobs,n=32 --brick 16 --no-vdb -q -o "$work/blobs" > /dev/null
commands=("--help"
          "info $work/blobs --json"
          "render $work/blobs -o $work/f.png --size 72x64 -q --tf mri"
          "prep synthetic:sparse,n=32 --brick 16 --no-vdb -q -o $work/s --force")
names=(help info render prep)
# One round: RUNS runs of command $2 by $1; prints "cpu_ms wall_ms" per run.
round() {
  local exe=$1 command=$2 start end
  # shellcheck disable=SC2086
  start=$(date +%s%N)
  /usr/bin/time -f "%U %S" -o "$work/cpu" bash -c 'for i in $(seq '"$runs"'); do "$0" '"$command"' > /dev/null 2>&1 || exit 1; done' "$exe" ||
    { echo "startup_ab.sh: $exe $command failed" >&2; exit 1; }
  end=$(date +%s%N)
  awk -v n="$runs" -v wall="$(( (end - start) / 1000 ))" '{ printf "%.1f %.1f\n", ($1 + $2) * 1000 / n, wall / 1000 / n }' "$work/cpu"
}
median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
echo "command,build,cpu_ms,wall_ms,rounds,runs" > "$out.csv"
for i in "${!commands[@]}"; do
  : > "$work/old" && : > "$work/new"
  for _ in $(seq "$rounds"); do
    round "$old" "${commands[$i]}" >> "$work/old"
    round "$new" "${commands[$i]}" >> "$work/new"
  done
  for b in old new; do
    echo "${names[$i]},$b,$(cut -d' ' -f1 "$work/$b" | median),$(cut -d' ' -f2 "$work/$b" | median),$rounds,$runs" >> "$out.csv"
  done
done
{
  echo "# A process's start: two builds side by side"
  echo
  echo "- Command: \`bash bench/startup_ab.sh $old $new --rounds $rounds --runs $runs\`"
  echo "- Date: $(date -u +%Y-%m-%d); machine: $(nproc) cores, $(uname -srm); old: commit $(cut -c1-7 "$(dirname "$old")/COMMIT" 2> /dev/null || echo unknown), new: commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD 2> /dev/null || echo ' with local changes')"
  echo "- Each figure: the median over $rounds rounds of one round's mean over $runs runs; the builds' rounds alternate."
  echo
  echo "| command | old CPU ms | new CPU ms | new/old | old wall ms | new wall ms |"
  echo "| --- | ---: | ---: | ---: | ---: | ---: |"
  for n in "${names[@]}"; do
    o=$(grep "^$n,old," "$out.csv") nw=$(grep "^$n,new," "$out.csv")
    awk -F, -v n="$n" -v o="$o" -v w="$nw" 'BEGIN { split(o, a, ","); split(w, b, ",");
      printf "| %s | %.1f | %.1f | %.2f | %.1f | %.1f |\n", n, a[3], b[3], b[3] / a[3], a[4], b[4] }'
  done
} > "$out.md"
cat "$out.md"
