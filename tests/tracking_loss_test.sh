#!/usr/bin/env bash
# Tracking loss on rendered data (issue 3, "lost tracking ... recover"): robot_sim renders the 200-frame sphere orbit
# with frames 80..99 replaced by a uniform grey view (lens covered), so every KLT track ends there and the ones after
# it have new ids. The pose solver reports LOST, restarts the preliminary phase, chains the new map through the
# odometry (2 % slip, heading drift, pan/tilt bias) and joins it to the old map by their common landmarks (Sim(3)).
# Bounds: the whole trajectory, both maps, against the truth after one Sim(3) alignment. Odometry chaining alone
# leaves about 3.4 mm (6-DOF) / 3.3 mm (4-DOF); the join brings it to 0.42 / 0.07 mm (docs/benchmarks.md).
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
FAILED=0
fail() { echo "FAIL: $*"; exit 1; }

source "$SRC/tests/accuracy_lib.sh"
render_orbit sphere "$WORK" --blank-first 80 --blank-count 20
GT="$WORK/gt/poses_gt.txt"

for model in 6dof 4dof; do
  "$BIN/objscan_replay" --log "$WORK/sim.lcmlog" --out "$WORK/$model" --no-dense --pose-model $model \
    > "$WORK/$model.out" 2>&1 || { tail -30 "$WORK/$model.out"; fail "replay ($model)"; }
  grep -q "joined to the old map" "$WORK/$model.out" || { grep -i "initialized\|joined" "$WORK/$model.out"; fail "$model: maps not joined"; }
  echo "$model: $(grep -o 'joined to the old map[^;]*' "$WORK/$model.out" | head -1)"
  "$BIN/objscan_evaluate" trajectory "$WORK/$model/trajectory.txt" "$GT" > "$WORK/$model-final.txt" || fail "evaluate"
  limit=0.6; [ $model = 4dof ] && limit=0.2
  check "$model final ATE RMSE over both maps (mm)" "$(value ate_rmse "$WORK/$model-final.txt")" "<=" $limit
  # 180 frames can be posed; a few after the loss go to the new preliminary phase.
  check "$model registered fraction" "$(value registered_fraction "$WORK/$model-final.txt")" ">=" 0.88
done
[ "$FAILED" = 0 ] || fail "accuracy below the bounds above"
echo "PASS: tracking loss recovered and the maps joined"
