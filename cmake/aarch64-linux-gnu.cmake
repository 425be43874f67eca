# Cross-compiling for 64-bit ARM (an Android phone's CPU architecture) on Debian/Ubuntu with
# g++-aarch64-linux-gnu and multiarch :arm64 libraries; test binaries run under qemu-user.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# No -L sysroot: the multiarch loader /lib/ld-linux-aarch64.so.1 (libc6:arm64) must load the
# multiarch libc; the cross toolchain's own /usr/aarch64-linux-gnu copy may be another build of
# glibc, and that mix hangs in pthread_create.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64)
