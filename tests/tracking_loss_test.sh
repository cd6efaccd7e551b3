#!/usr/bin/env bash
# Tracking loss on rendered data (issue 3, "lost tracking ... recover"): robot_sim renders the 200-frame sphere orbit
# with frames 80..99 replaced by a uniform grey view (lens covered), so every KLT track ends there and the ones after
# it have new ids. The pose solver reports LOST, restarts the preliminary phase, chains the new map through the
# odometry (2 % slip, heading drift, pan/tilt bias) and joins it to the old map: by their common landmarks (Sim(3),
# the default), or, with that join off (--join-search 0), by position (the old landmarks projected from the new
# span's last pose pair with its tracks; one frame's pose moves the new map). Bounds: the whole trajectory against the
# truth after one Sim(3) alignment. Odometry chaining alone leaves 3.4 mm (6-DOF) / 3.3 mm (4-DOF); joined by
# landmarks 0.42 / 0.07 mm; by position 2.2 / 0.29 mm (docs/benchmarks.md).
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
FAILED=0
fail() { echo "FAIL: $*"; exit 1; }

source "$SRC/tests/accuracy_lib.sh"
render_orbit sphere "$WORK" --blank 80,20
GT="$WORK/gt/poses_gt.txt"

for model in 6dof 4dof; do
  for mode in landmarks position; do
    args=""; expect="joined to the old map by [0-9]* landmarks"; limit=0.6; [ $model = 4dof ] && limit=0.2
    if [ $mode = position ]; then
      args="--join-search 0"; expect="joined to the old map by position"; limit=2.6; [ $model = 4dof ] && limit=0.5
    fi
    run="$model-$mode"
    "$BIN/objscan_replay" --log "$WORK/sim.lcmlog" --out "$WORK/$run" --no-dense --pose-model $model \
      --pose-solver-args "$args" > "$WORK/$run.out" 2>&1 || { tail -30 "$WORK/$run.out"; fail "replay ($run)"; }
    grep -q "$expect" "$WORK/$run.out" || { grep -i "initialized\|joined\|relocalized" "$WORK/$run.out"; fail "$run: no '$expect'"; }
    echo "$run: $(grep -o "$expect[^;]*" "$WORK/$run.out" | head -1)"
    "$BIN/objscan_evaluate" trajectory "$WORK/$run/trajectory.txt" "$GT" > "$WORK/$run-final.txt" || fail "evaluate"
    check "$run final ATE RMSE over both maps (mm)" "$(value ate_rmse "$WORK/$run-final.txt")" "<=" $limit
    # 180 frames can be posed; a few after the loss go to the new preliminary phase.
    check "$run registered fraction" "$(value registered_fraction "$WORK/$run-final.txt")" ">=" 0.88
  done
done
[ "$FAILED" = 0 ] || fail "accuracy below the bounds above"
echo "PASS: tracking loss recovered and the maps joined"
