#!/usr/bin/env bash
# Benchmark (issue 25: "the whole 200-frame image-only run stays under 15 s"): the simulator's sphere orbit without
# odometry, exported as an image folder (images + calib.yaml, nobody's flags), run with `objscan run --dataset` on a
# live bus in a private network namespace (root); prints the wall time and the accuracy after Sim(3).
# Usage: scripts/bench_image_only.sh [FRAMES]   (build first: ./objscan build)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BIN="${OBJSCAN_BUILD_DIR:-$ROOT/build}/bin"
FRAMES="${1:-200}"
fail() { echo "bench_image_only: $*" >&2; exit 1; }
source "$ROOT/tests/netns_lib.sh"
netns_require
NS=$(netns_name bench); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
"$BIN/robot_sim" --lcm-url "file://$WORK/sim.lcmlog?mode=w" --scene "$ROOT/drivers/robot_sim/scenes/sphere.scene" \
  --frames "$FRAMES" --realtime=false --encoding jpeg --jpeg-quality 95 --odometry=false --ground-truth-dir "$WORK/gt" \
  > "$WORK/sim.out" 2>&1 || fail "robot_sim"
"$BIN/objscan_export" --log "$WORK/sim.lcmlog" --out "$WORK/folder" > "$WORK/export.out" 2>&1 || fail "objscan_export"
start=$(date +%s.%N)
in_ns "$NS" "$ROOT/objscan" run --dataset "$WORK/folder" --out "$WORK/run" > "$WORK/run.out" 2>&1 ||
  { tail -n 20 "$WORK/run.out"; fail "objscan run --dataset"; }
end=$(date +%s.%N)
"$BIN/objscan_evaluate" trajectory "$WORK/run/trajectory_online.txt" "$WORK/folder/poses_gt.txt" > "$WORK/online.txt"
"$BIN/objscan_evaluate" surface "$WORK/run/model_mesh.ply" "$WORK/gt/target_surface.ply" --truth-mesh "$WORK/gt/target_mesh.ply" \
  --align "$WORK/run/trajectory.txt" "$WORK/folder/poses_gt.txt" --visible-from "$WORK/folder/poses_gt.txt" > "$WORK/mesh.txt"
v() { awk -v k="$1" '$1==k {print $2}' "$2"; }
printf 'image-only %s-frame run: wall %.1f s (target < 15 s, 30 Hz playback alone is %.1f s)\n' "$FRAMES" \
  "$(echo "$end - $start" | bc)" "$(echo "$FRAMES / 30" | bc -l)"
printf '  online ATE %s mm (Sim(3)), mesh p90 %s mm, completeness %s, scale %s\n' "$(v ate_rmse "$WORK/online.txt")" \
  "$(v accuracy_p90 "$WORK/mesh.txt")" "$(v completeness "$WORK/mesh.txt")" \
  "$(grep -o '"scale": "[^"]*' "$WORK/run/summary.json" | cut -c11-)"
