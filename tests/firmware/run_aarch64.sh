#!/usr/bin/env bash
# The aarch64 Linux test: cross-builds tests/firmware/aarch64 (sph::model, sph::c, sph::core and
# their tests) with Debian's aarch64-linux-gnu toolchain and runs the tests under qemu-aarch64.
#   run_aarch64.sh SRC_DIR WORK_DIR
# A missing tool is an error (cmake/install-deps.sh installs them), never a skip.
set -euo pipefail
src=$1 work=$2
for tool in aarch64-linux-gnu-g++ aarch64-linux-gnu-gcc qemu-aarch64; do
  if ! command -v "$tool" >/dev/null; then
    echo "error: $tool not found: the firmware tests need the packages of cmake/install-deps.sh" >&2
    exit 1
  fi
done
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
start=$(date +%s)
cmake -S "$src/tests/firmware/aarch64" -B "$work" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$src/tests/firmware/aarch64/toolchain.cmake" -DSPH_SOURCE_DIR="$src" "${launcher[@]}" \
  >"$work.configure.log" 2>&1 || { cat "$work.configure.log"; exit 1; }
cmake --build "$work" -j2 >"$work.build.log" 2>&1 || { tail -50 "$work.build.log"; exit 1; }
built=$(date +%s)
echo "built for aarch64 in $((built - start)) s"
# The ELF header's e_machine: 183 is AArch64.
machine=$(od -An -tu2 -j18 -N2 "$work/core_test" | tr -d ' ')
if [ "$machine" != 183 ]; then
  echo "FAIL: core_test is no aarch64 program (ELF machine $machine)"
  exit 1
fi
echo "core_test and model_test: ELF for AArch64 (e_machine 183), run by qemu-aarch64"
ctest --test-dir "$work" -j2 --output-on-failure 2>&1 | tail -15
status=${PIPESTATUS[0]}
echo "ran under qemu-aarch64 in $(($(date +%s) - built)) s"
exit "$status"
