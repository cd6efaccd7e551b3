#!/usr/bin/env bash
# Quick start (1): installs what is missing, builds, and runs the main job, the closed loop: in a simulated room
# (room_01: walls, furniture, a rug, an untextured distractor) the robot explores from a start that does not face
# the target, the object finder finds the small textured target, the planner drives around it and adds next views,
# while separate processes track, estimate poses and model it over LCM; the session is logged. Output in
# ${1:-out/demo} (model_mesh.ply, target.json, plan.json, summary.json); exits non-zero when no model came out.
# Takes 4-8 min on 2 cores.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
"$ROOT/scripts/setup_deps.sh"
"$ROOT/objscan" build
"$ROOT/objscan" run --sim --scene room_01 --out "${1:-$ROOT/out/demo}"
