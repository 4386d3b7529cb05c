#!/bin/sh
# Time and peak memory of sph_calibrate (default options: the residual trace included) and of
# sph_measure (default: 200 calibration draws) on points files of 20 k, 200 k and 2 M rows, to show
# that both grow linearly with the rows. Wall time, CPU time (user + system, all threads) and peak
# RSS from GNU time; on a machine shared with other work the CPU time is the steadier figure.
#
#   bench/rows_2m.sh [BUILD_DIR] [ROWS...]      (default rows: 20000 200000 2000000)
#
# The grids have twice as many theta steps as phi rings (theta x phi = rows). Takes about 10 minutes on 2 cores.
# Not a test: its figures depend on the machine and on what else runs on it.
set -eu
build=${1:-build}
[ $# -gt 0 ] && shift
rows=${*:-20000 200000 2000000}
source_dir=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM
timed() {  # label, command...: "label: wall W s, CPU C s, peak RSS M MB"
  label=$1
  shift
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" >/dev/null 2>"$work/err" || {
    cat "$work/err" >&2
    exit 1
  }
  awk -v l="$label" '{ printf "%s: wall %.2f s, CPU %.2f s, peak RSS %.0f MB\n", l, $1, $2 + $3, $4 / 1024 }' \
    "$work/time"
}
"$build/apps/sph_calibrate" "$source_dir/data/example/points.txt" -q -o "$work/cal.json"
echo "$(nproc) cores, load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
for n in $rows; do
  phi=$(awk -v n="$n" 'BEGIN { printf "%d", sqrt(n / 2) }')
  theta=$((n / phi))
  "$build/apps/sph_simulate" -o "$work/cal_rows.txt" --theta-steps "$theta" --phi-steps "$phi"
  "$build/apps/sph_simulate" -o "$work/measure_rows.txt" --theta-steps "$theta" --phi-steps "$phi" \
    --center-mm 1,1,0.5 --seed 3
  m=$((theta * phi))
  timed "sph_calibrate, $m rows" "$build/apps/sph_calibrate" "$work/cal_rows.txt" -q --no-progress
  timed "sph_calibrate --no-trace, $m rows" "$build/apps/sph_calibrate" "$work/cal_rows.txt" -q --no-trace \
    --no-progress
  timed "sph_measure (200 draws), $m rows" "$build/apps/sph_measure" "$work/measure_rows.txt" -c "$work/cal.json" -q \
    --no-progress
  timed "sph_measure --uncertainty-samples 0, $m rows" "$build/apps/sph_measure" "$work/measure_rows.txt" \
    -c "$work/cal.json" -q --uncertainty-samples 0 --no-progress
  rm -f "$work/cal_rows.txt" "$work/measure_rows.txt"
done
