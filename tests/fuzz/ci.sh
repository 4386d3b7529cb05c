#!/usr/bin/env bash
# CI's fuzz step: builds the libFuzzer targets with clang-14 and runs each briefly (run.sh).
# Installs clang-14 and libclang-rt-14-dev (libFuzzer) when missing and possible; without them
# the step is skipped with the reason, since the default build needs neither.
#
# Usage: tests/fuzz/ci.sh [SECONDS_PER_TARGET]    (default 20)
set -euo pipefail
cd "$(dirname "$0")/../.."
secs=${1:-20}
fuzzer_runtime() { compgen -G "/usr/lib/llvm-14/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a" >/dev/null; }
if ! command -v clang++-14 >/dev/null || ! fuzzer_runtime; then
  sudo=""
  [[ $(id -u) -eq 0 ]] || sudo="sudo -n"
  echo "fuzz: installing clang-14 libclang-rt-14-dev"
  { $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      clang-14 libclang-rt-14-dev; } >/dev/null 2>&1 || true
fi
if ! command -v clang++-14 >/dev/null || ! fuzzer_runtime; then
  echo "fuzz: SKIPPED: clang-14 with libFuzzer is not installed and could not be (apt-get install clang-14 libclang-rt-14-dev)"
  exit 0
fi
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
exec tests/fuzz/run.sh -t "$secs"
