#!/usr/bin/env bash
# Runs the libFuzzer targets of the "asan" preset (build-asan/, built with the tests) for a time each.
#
# Usage: tests/fuzz/run.sh [-t SECONDS] [TARGET...]     (default 25 s each, every target)
#
# Each target starts from its committed seed corpus (tests/fuzz/corpus/<target>/, read only) and
# keeps what it finds in build-asan/corpus/<target>/, with the libFuzzer flags of
# tests/fuzz/<target>.options when there is one (one line); a crash, leak, timeout or sanitizer report
# is saved as build-asan/artifacts/<target>-crash-… (reproduce: build-asan/tests/fuzz/<target> FILE)
# and fails the run. Prints one line per target (runs, cov:, ft:) and "fuzz: N passed, N failed".
set -uo pipefail
cd "$(dirname "$0")/../.."
secs=25
if [[ ${1:-} == -t ]]; then secs=$2; shift 2; fi
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] ||
  targets=(fuzz_points fuzz_xyz fuzz_calibration fuzz_calibration_nesting fuzz_calibration_blob fuzz_dcc_settings fuzz_candump fuzz_can_frames fuzz_sdo_nmt
           fuzz_acquired_config)
build=build-asan
passed=0 failed=0
for t in "${targets[@]}"; do
  exe="$build/tests/fuzz/$t"
  if [[ ! -x $exe ]]; then
    echo "fuzz: $t: not built ($exe); build with: cmake --preset asan && cmake --build --preset asan"
    failed=$((failed + 1))
    continue
  fi
  mkdir -p "$build/corpus/$t" "$build/artifacts"
  log="$build/artifacts/$t.log"
  options=()
  [[ -f tests/fuzz/$t.options ]] && read -ra options <"tests/fuzz/$t.options"
  # -rss_limit_mb: ASan's shadow is not counted; 2 GB leaves room for the other jobs.
  if "$exe" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 "${options[@]}" \
       -artifact_prefix="$build/artifacts/$t-" "$build/corpus/$t" "tests/fuzz/corpus/$t" >"$log" 2>&1; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    last=$(grep -E '^#[0-9]+' "$log" | tail -1)
    cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
    ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
    echo "fuzz: $t: ok, ${secs} s, ${runs:-?} runs, cov: ${cov:-?} ft: ${ft:-?}"
    passed=$((passed + 1))
  else
    echo "fuzz: $t: FAILED (log $log); last lines:"
    tail -40 "$log"
    failed=$((failed + 1))
  fi
done
echo "fuzz: $passed passed, $failed failed"
[[ $failed -eq 0 ]]
