#!/usr/bin/env bash
# The bare-metal firmware test: builds tests/firmware/cortex_m with Debian's arm-none-eabi toolchain
# (no exceptions, no RTTI, no heap), runs it on qemu's mps2-an500 (Cortex-M7) with semihosting, and
# compares its points with the host's (firmware_host compare).
#   run_cortex_m.sh compare SRC_DIR WORK_DIR FIRMWARE_HOST CALIBRATION POINTS...
#   run_cortex_m.sh heap SRC_DIR WORK_DIR     the link of a program that calls malloc() must fail
# A missing tool is an error (cmake/install-deps.sh installs them), never a skip.
set -euo pipefail
mode=$1 src=$2 work=$3
shift 3
for tool in arm-none-eabi-gcc arm-none-eabi-g++ arm-none-eabi-size qemu-system-arm; do
  if ! command -v "$tool" >/dev/null; then
    echo "error: $tool not found: the firmware tests need the packages of cmake/install-deps.sh" >&2
    exit 1
  fi
done
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
mkdir -p "$work/gen"
configure() {
  cmake -S "$src/tests/firmware/cortex_m" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_TOOLCHAIN_FILE="$src/tests/firmware/cortex_m/toolchain.cmake" -DSPH_SOURCE_DIR="$src" \
    -DSPH_GEN_DIR="$work/gen" "${launcher[@]}" >"$work/configure.log" || { cat "$work/configure.log"; exit 1; }
}

if [ "$mode" = heap ]; then
  # Any fixture links: the C sources of a calibration and readings are only needed to compile.
  [ -f "$work/gen/calibration.c" ] || printf '#include <stddef.h>\nconst unsigned char sph_calibration_blob[1] = {0};\nconst size_t sph_calibration_blob_size = 1;\n' >"$work/gen/calibration.c"
  [ -f "$work/gen/readings.c" ] || printf '#include <stddef.h>\n#include "sph/c/compensation.h"\nconst sph_reading sph_test_readings[1] = {{0, 0, 0}};\nconst size_t sph_test_readings_count = 1;\n' >"$work/gen/readings.c"
  configure
  if cmake --build "$work/build" --target heap_refused_fw >"$work/heap.log" 2>&1; then
    echo "FAIL: a program that calls malloc() linked"
    exit 1
  fi
  if ! grep -q "undefined reference to \`__wrap_malloc'" "$work/heap.log"; then
    cat "$work/heap.log"
    echo "FAIL: the link failed for another reason than malloc"
    exit 1
  fi
  echo "firmware: the link refuses malloc(): $(grep -m1 "undefined reference" "$work/heap.log")"
  exit 0
fi

host=$1 cal=$2
shift 2
"$host" fixture "$cal" "$work/gen" "$@"
configure
cmake --build "$work/build" --target compensate_fw >"$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
elf="$work/build/compensate_fw.elf"
echo "code and data (arm-none-eabi-size):"
arm-none-eabi-size "$elf"
fixture=0
while read -r _ size _ name; do
  case $name in sph_test_readings | sph_calibration_blob) fixture=$((fixture + 16#$size)) ;; esac
done < <(arm-none-eabi-nm -S "$elf")
echo "of its text, the fixture (readings and calibration blob): $fixture bytes"
echo "largest stack frames (-fstack-usage):"
# awk, not head: head would close the pipe early and sort's SIGPIPE fail the script under pipefail.
find "$work/build" -name '*.su' -exec cat {} + | sort -t$'\t' -k2 -n -r | awk 'NR <= 4' | sed 's/^.*include\///; s/^.*src\///' 
rm -f "$work/target.txt"
timeout 120 qemu-system-arm -M mps2-an500 -display none -monitor none -serial none -icount shift=0 \
  -chardev file,id=sh,path="$work/target.txt" -semihosting-config enable=on,target=native,chardev=sh \
  -kernel "$elf" </dev/null || { echo "FAIL: the target program ended with status $?"; tail -3 "$work/target.txt"; exit 1; }
"$host" compare "$cal" "$work/target.txt" "$@"
