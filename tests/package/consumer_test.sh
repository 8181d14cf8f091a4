#!/usr/bin/env bash
# The CMake package as a user meets it: install this build to a temporary prefix, build
# examples/ against it with find_package(gaussmesh), and run the program in memory and on a
# fixture file. Usage: consumer_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 source=$2
work=$(mktemp -d "${TMPDIR:-/tmp}/gaussmesh-consumer.XXXXXX")
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
test -f "$work/prefix/include/gaussmesh/gaussmesh.h"
test -f "$work/prefix/lib/cmake/gaussmesh/gaussmeshConfig.cmake"
cmake -S "$source/examples" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/build" -j2 >/dev/null
"$work/build/simplify_file"
"$work/build/simplify_file" "$source/fixtures/real/cow.off" "$work/cow.drc"
test -s "$work/cow.drc"
echo "consumer_test: find_package(gaussmesh) from $work/prefix: built and ran"
