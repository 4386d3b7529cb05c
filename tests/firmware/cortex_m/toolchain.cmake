# Debian's bare-metal Arm toolchain (gcc-arm-none-eabi, libnewlib-arm-none-eabi) for a Cortex-M7
# with its double-precision FPU, as on qemu's mps2-an500.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(SPH_CPU_FLAGS "-mcpu=cortex-m7 -mfpu=fpv5-d16 -mfloat-abi=hard -mthumb")
set(CMAKE_C_FLAGS_INIT "${SPH_CPU_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT "${SPH_CPU_FLAGS}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${SPH_CPU_FLAGS}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
