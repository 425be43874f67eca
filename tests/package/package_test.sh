#!/usr/bin/env bash
# Installs the build into a fresh prefix, then builds and runs the README's C example against
# it three ways: find_package(mcpt) with mcpt::mcpt and mcpt::mcpt_static, and pkg-config.
# Usage: package_test.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >/dev/null
cmake -S "$src/tests/package" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" \
      -DEXAMPLE="$src/tests/c_example.c" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/consumer" >/dev/null
"$work/consumer/example_shared" "" "$work/shared.png"
"$work/consumer/example_static" "" "$work/static.png"
export PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig"
cc -std=c99 -Wall -Wextra -pedantic -Werror "$src/tests/c_example.c" -o "$work/example_pc" \
   $(pkg-config --cflags --libs mcpt) -Wl,-rpath,"$work/prefix/lib"
"$work/example_pc" "" "$work/pkgconfig.png"
test -s "$work/shared.png" && test -s "$work/static.png" && test -s "$work/pkgconfig.png"
echo "find_package(mcpt) shared and static, and pkg-config mcpt $(pkg-config --modversion mcpt): ok"
