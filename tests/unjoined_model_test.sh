#!/usr/bin/env bash
# A model built across a map restart that was never joined is loud (issue 24: runs that modeled "in the wrong frame"
# ended with status ok). The session supervisor runs the sphere orbit with frames 80..99 rendered grey (every track
# ends, the pose solver restarts its map) and the pose solver's map join and relocalization by position switched off
# (--join-search 0 --relocalize-search 0: the new map stays chained by the odometry only), in a private multicast
# namespace. The dense modeler builds its model from
# frames on both sides of the restart, so the session must end "failed" with a message that names the restart and
# says what to try, and exit non-zero. The same run with the defaults (relocalized by position) ends "ok".
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name unjoined); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT

run() {  # NAME PORT POSE_SOLVER_ARGS: the session's exit code in $WORK/NAME.rc
  local name="$1" url="udpm://239.255.76.67:$2?ttl=0&recv_buf_size=4194304" out="$WORK/$1" rc=0
  cat > "$WORK/$name.procs" <<PROCS
tracker processor $BIN/tracker --lcm-url '$url'
pose_solver processor $BIN/pose_solver --lcm-url '$url' --output-dir '$out' $3
dense_modeler processor $BIN/dense_modeler --lcm-url '$url' --output-dir '$out'
robot_sim driver $BIN/robot_sim --lcm-url '$url' --scene '$SRC/drivers/robot_sim/scenes/sphere.scene' --frames 200 --blank 80,20 --realtime=false --lockstep-channel CAMERA_POSE
PROCS
  in_ns "$NS" "$BIN/objscan_session" --out "$out" --processes "$WORK/$name.procs" --lcm-url "$url" \
    --finish-on dense_modeler --expected-frames 200 > "$WORK/$name.out" 2>&1 || rc=$?
  echo "$rc" > "$WORK/$name.rc"
}

run unjoined 7701 "--join-search 0 --relocalize-search 0"
s="$WORK/unjoined/summary.json"
[ -f "$s" ] || { tail -n 30 "$WORK/unjoined.out"; fail "no summary.json"; }
grep -q "maps never joined" "$WORK/unjoined/logs/pose_solver.log" || { tail -n 20 "$WORK/unjoined/logs/pose_solver.log"; fail "the pose solver did not report the unjoined map"; }
[ "$(cat "$WORK/unjoined.rc")" != 0 ] || { cat "$s"; fail "model across an unjoined restart, yet exit 0"; }
grep -q '"status": "failed"' "$s" || { cat "$s"; fail "model across an unjoined restart, yet status not failed"; }
grep -q '"error": "the model mixes two frames: the pose solver.s map restarted at frame [0-9]*[^"]*Run again' "$s" ||
  { grep '"error"' "$s"; fail "the error does not name the restart and what to try"; }
echo "unjoined: exit $(cat "$WORK/unjoined.rc"), $(grep -o '"error": "[^"]*' "$s" | cut -c11-150)..."

run joined 7702 ""
s="$WORK/joined/summary.json"
[ "$(cat "$WORK/joined.rc")" = 0 ] || { grep '"error"' "$s"; fail "the joined run failed"; }
grep -q '"status": "ok"' "$s" || { cat "$s"; fail "joined run: status not ok"; }
echo "PASS: a model across an unjoined map restart fails loudly; the joined run is ok"
