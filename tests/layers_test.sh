#!/usr/bin/env bash
# The layer rule's check (cmake/ObjscanLayers.cmake) fails a configure where a library declared LCM-free reaches LCM
# through another library, naming the path, and passes one where it does not. (The project's own configure runs the
# same check on every *_core library.)
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
mkdir -p "$WORK/project"
cat > "$WORK/project/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.16)
project(layers_check NONE)
include($SRC/cmake/ObjscanLayers.cmake)
add_library(lcm::lcm INTERFACE IMPORTED)
add_library(objscan_common INTERFACE)
target_link_libraries(objscan_common INTERFACE lcm::lcm)
add_library(helper INTERFACE)
target_link_libraries(helper INTERFACE \$<LINK_ONLY:objscan_common>)
add_library(fine_core INTERFACE)
add_library(bad_core INTERFACE)
target_link_libraries(bad_core INTERFACE helper)
objscan_require_lcm_free(fine_core)
if(VIOLATE)
  objscan_require_lcm_free(bad_core)
endif()
objscan_check_layers()
CMAKE
cmake -S "$WORK/project" -B "$WORK/ok" -DVIOLATE=OFF > "$WORK/ok.out" 2>&1 || { cat "$WORK/ok.out"; echo "FAIL: a clean layering was refused"; exit 1; }
if cmake -S "$WORK/project" -B "$WORK/bad" -DVIOLATE=ON > "$WORK/bad.out" 2>&1; then
  cat "$WORK/bad.out"; echo "FAIL: a core library linking LCM through another passed the check"; exit 1
fi
grep -q "bad_core must stay LCM-free" "$WORK/bad.out" && grep -q "bad_core -> helper -> objscan_common" "$WORK/bad.out" ||
  { cat "$WORK/bad.out"; echo "FAIL: the error does not name the path"; exit 1; }
grep -A2 "must stay" "$WORK/bad.out" | head -3
echo PASS
