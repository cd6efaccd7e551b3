#!/usr/bin/env bash
# Quick start (1): installs what is missing, builds, and runs the main job: the simulated robot orbits a textured
# object on the floor while separate processes track, estimate poses and model it over LCM; the session is logged.
# Output in ${1:-out/demo}.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
"$ROOT/scripts/setup_deps.sh"
"$ROOT/objscan" build
"$ROOT/objscan" run --sim --scene sphere --out "${1:-$ROOT/out/demo}"
