#!/usr/bin/env bash
# The CMake package as a user meets it: install this build to a temporary prefix, build
# examples/ against it with find_package(gaussmesh), and run the program in memory and on a
# fixture file. Usage: consumer_test.sh BUILD_DIR SOURCE_DIR [SANITIZERS]
# SANITIZERS is the build's GAUSSMESH_SANITIZE: its installed libraries call the sanitizer
# runtimes, so the consumer compiles and links with the same -fsanitize (and runs sanitized too).
set -euo pipefail
build=$1 source=$2 sanitize=${3:-}
flags=()
if [ -n "$sanitize" ]; then
  flags=(-DCMAKE_CXX_FLAGS="-fsanitize=$sanitize -fno-sanitize-recover=undefined" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$sanitize")
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/gaussmesh-consumer.XXXXXX")
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
test -f "$work/prefix/include/gaussmesh/gaussmesh.h"
test -f "$work/prefix/lib/cmake/gaussmesh/gaussmeshConfig.cmake"
cmake -S "$source/examples" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release "${flags[@]}" >/dev/null
cmake --build "$work/build" -j2 >/dev/null
"$work/build/simplify_file"
"$work/build/simplify_file" "$source/fixtures/real/cow.off" "$work/cow.drc"
test -s "$work/cow.drc"
echo "consumer_test: find_package(gaussmesh) from $work/prefix: built and ran"
