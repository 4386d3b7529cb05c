#!/bin/sh
# The project's calibration beside what a user would write instead (SciPy's least_squares,
# method 'lm', vectorised NumPy model: bench/peer_scipy.py), on the same points files, in one
# process tree; then the Monte Carlo study, the trace's memory and the 2 M-row runs of the apps.
#
#   bench/peer_scipy.sh [BUILD_DIR] [--quick]
#
# Needs /usr/bin/python3 with numpy and scipy (Debian: apt-get install python3-scipy) and a Release
# build with the benchmarks (default build/). --quick leaves out the 2 M-row runs (about 5 minutes).
# Not a test: its figures depend on the machine and on what else runs on it.
set -eu
build=build
quick=0
for a in "$@"; do
  case "$a" in
    --quick) quick=1 ;;
    *) build="$a" ;;
  esac
done
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM

median() {  # the median of the "<name>_median" aggregate of a benchmark's console output: wall, CPU [ms]
  awk -v n="$1_median" '$1 == n { print $2, $4 }'
}

echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo

scipy288=
for grid in "24 12" "96 48"; do
  set -- $grid
  points="$work/points_$1x$2.txt"
  "$build/apps/sph_simulate" -o "$points" --theta-steps "$1" --phi-steps "$2"
  n=$(($1 * $2))
  ours=$(SPH_BENCH_POINTS="$points" "$build/bench/calibrate_bench" --benchmark_filter='^BM_CalibrateFile$' \
    --benchmark_repetitions=10 --benchmark_report_aggregates_only=true 2>/dev/null | median BM_CalibrateFile)
  reps=50
  [ "$n" -gt 1000 ] && reps=10
  "$py" "$here/peer_scipy.py" "$points" --repetitions "$reps" >"$work/peer.txt"
  field() { awk -v k="$1" '$1 == k { printf "%.3g", $2 }' "$work/peer.txt"; }
  [ "$n" -eq 288 ] && scipy288=$(field scipy_median_ms)
  echo "calibration of $n points (solve, same file), medians: sph ${ours% *} ms wall, ${ours#* } ms CPU;" \
    "scipy $(field scipy_median_ms) ms wall, $(field scipy_cpu_median_ms) ms CPU ($(field scipy_nfev) model" \
    "evaluations); ratio $(awk -v a="$(field scipy_median_ms)" -v b="${ours% *}" 'BEGIN { printf "%.0f", a / b }')x wall," \
    "$(awk -v a="$(field scipy_cpu_median_ms)" -v b="${ours#* }" 'BEGIN { printf "%.0f", a / b }')x CPU"
done
echo "numpy $(awk '$1 == "numpy_version" { print $2 }' "$work/peer.txt"), BLAS/LAPACK loaded:" \
  "$(awk '$1 == "numpy_blas" { print $2 }' "$work/peer.txt")"
echo

# The paper's study: 4 x 1000 calibrations of 288 points, on 2 threads, the median of 5 runs;
# scipy's figure is 4000 times its median on 288 points above (the same calibration, other noise),
# not a run of 4000 fits.
study=$("$build/bench/montecarlo_bench" --benchmark_filter='^BM_DefaultStudy/2/' --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true 2>/dev/null | awk '$1 ~ /^BM_DefaultStudy\/2\/.*_median$/ { print $2, $0 }')
study_ms=$(echo "$study" | cut -d' ' -f1)
study_rss=$(echo "$study" | sed -n 's/.*peak_rss_MB=\([0-9.]*[kM]*\).*/\1/p')
echo "Monte Carlo study 4 x 1000 x 288 points, 2 threads: sph $study_ms ms wall (peak RSS $study_rss MB);" \
  "scipy 4000 x $scipy288 ms = $(awk -v a="$scipy288" 'BEGIN { printf "%.1f", 4 * a }') s on one thread," \
  "ratio $(awk -v a="$scipy288" -v b="$study_ms" 'BEGIN { printf "%.0f", 4000 * a / b }')x"
trace=$("$build/bench/trace_bench" --benchmark_filter='^BM_Trace4608' --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true 2>/dev/null | awk '$1 ~ /^BM_Trace4608.*_median$/')
echo "trace of 4608 points (paper's study, 96 x 48), 2 threads: median $(echo "$trace" | awk '{ print $2 }') ms," \
  "peak RSS $(echo "$trace" | sed -n 's/.*peak_rss_MB=\([0-9.]*[kM]*\).*/\1/p') MB"
undeclared=$("$build/bench/trace_bench" --benchmark_filter='^BM_Trace/undeclared:1/threads:2$' --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true 2>/dev/null | median BM_Trace/undeclared:1/threads:2)
echo "trace of data/example/undeclared (576 points), 2 threads: median ${undeclared% *} ms wall, ${undeclared#* } ms CPU"

[ "$quick" -eq 1 ] && exit 0
echo
"$here/rows_2m.sh" "$build"
