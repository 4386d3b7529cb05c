#!/usr/bin/env bash
# Compensation per point before and after a change, side by side in one run: builds
# bench/compensation_bench.cpp against the headers of REF (a commit) and of this checkout with the
# same flags as a Release build, checks that both give the same points to the last bit, and runs
# them alternately, ROUNDS times each.
#   bench/compensation_before_after.sh REF [ROUNDS]
set -euo pipefail
ref=$1 rounds=${2:-5}
here=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d /tmp/sph-compensation-bench.XXXXXX)
trap 'git -C "$here" worktree remove --force "$work/ref" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
git -C "$here" worktree add --detach "$work/ref" "$ref" >/dev/null 2>&1
flags=(-std=c++17 -O3 -DNDEBUG -isystem /usr/include/eigen3)
g++ "${flags[@]}" -I "$work/ref/include" "$here/bench/compensation_bench.cpp" -o "$work/before" -lbenchmark -lpthread
g++ "${flags[@]}" -I "$here/include" "$here/bench/compensation_bench.cpp" -o "$work/after" -lbenchmark -lpthread
echo "before: $(git -C "$work/ref" rev-parse --short HEAD), after: $(git -C "$here" rev-parse --short HEAD)$(git -C "$here" diff --quiet || echo ' (with uncommitted changes)')"
if diff <("$work/before" --checksum) <("$work/after" --checksum) >/dev/null; then
  echo "points identical to the last bit:"
  "$work/after" --checksum | sed 's/^/  /'
else
  echo "points DIFFER:"
  diff <("$work/before" --checksum) <("$work/after" --checksum) || true
  exit 1
fi
echo "uptime: $(uptime | sed 's/.*load/load/')"
for ((i = 1; i <= rounds; ++i)); do
  for which in before after; do
    "$work/$which" --benchmark_min_time=0.5 --benchmark_format=csv 2>/dev/null |
      awk -F, -v w="$which" -v r="$i" '/^"BM_Compensate/ {gsub(/"/, "", $1); printf "%s %s round %d %.1f ns/point\n", w, $1, r, $NF * 1e9}'
  done
done | tee "$work/rows"
echo "medians (ns per point):"
for bm in effects:0 effects:1; do
  for which in before after; do
    m=$(grep "^$which BM_Compensate/$bm " "$work/rows" | awk '{print $(NF-1)}' | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
    echo "  $bm $which $m"
  done
done
