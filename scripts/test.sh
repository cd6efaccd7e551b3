#!/usr/bin/env bash
# Quick start (2): installs what is missing, builds everything and runs every test (unit, replay, live replay,
# accuracy). CI runs exactly this (.ci/run).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
"$ROOT/scripts/setup_deps.sh"
export OBJSCAN_BUILD_DIR="${OBJSCAN_BUILD_DIR:-$ROOT/build}"
"$ROOT/objscan" build
cd "$OBJSCAN_BUILD_DIR"
ctest --output-on-failure --timeout 900 -j "${OBJSCAN_TEST_JOBS:-2}"
