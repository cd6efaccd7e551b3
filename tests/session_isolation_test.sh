#!/usr/bin/env bash
# Sessions that never hear each other (issue 26), in a private multicast namespace:
# 1. two `objscan run --sim --orbit` started together without --lcm-url: each picks a bus of its own (summary.json
#    "lcm_url" differs), each ends "ok" with exactly its frames, hears no foreign process, and poses its orbit as a run
#    alone does (registered fraction and ATE against its own truth);
# 2. two runs forced onto one URL: each hears the other's processes, ends at once with a non-zero exit, status
#    "failed" and an error that says what to do (a bus of its own);
# 3. another session's sensor frames alone (its log played onto a live run's bus): refused by their session id, and
#    the run fails loudly.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name isolation); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
FRAMES=40

run() {  # NAME [options...]: objscan run --sim --orbit into $WORK/NAME, exit code in $WORK/NAME.rc
  local name="$1"; shift
  local rc=0
  in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames $FRAMES --out "$WORK/$name" "$@" \
    > "$WORK/$name.out" 2>&1 || rc=$?
  echo "$rc" > "$WORK/$name.rc"
}

# 1. Two runs at once, each on its own bus.
run a & run b & wait
for r in a b; do
  s="$WORK/$r/summary.json"
  [ "$(cat "$WORK/$r.rc")" = 0 ] || { tail -n 20 "$WORK/$r.out"; fail "run $r: exit $(cat "$WORK/$r.rc")"; }
  grep -q '"status": "ok"' "$s" || { cat "$s"; fail "run $r: status not ok"; }
  grep -q "\"frames\": $FRAMES," "$s" || { grep '"frames"' "$s"; fail "run $r: expected $FRAMES frames"; }
  ! grep -q '"foreign_processes"' "$s" || { grep -A3 foreign "$s"; fail "run $r heard another session"; }
  "$BIN/objscan_evaluate" trajectory "$WORK/$r/trajectory.txt" "$WORK/$r/ground_truth/poses_gt.txt" > "$WORK/$r.eval"
  reg=$(awk '$1=="registered_fraction"{print $2}' "$WORK/$r.eval")
  ate=$(awk '$1=="ate_rmse"{print $2}' "$WORK/$r.eval")
  awk -v r="$reg" -v a="$ate" 'BEGIN{exit !(r >= 0.9 && a <= 2.0)}' ||
    fail "run $r: registered $reg, ATE $ate mm (alone: all frames, under 1 mm)"
  echo "run $r: $(grep -o '"lcm_url": "[^"]*' "$s" | cut -c13-), registered $reg, ATE $ate mm"
done
url_a=$(grep -o '"lcm_url": "[^"]*' "$WORK/a/summary.json")
url_b=$(grep -o '"lcm_url": "[^"]*' "$WORK/b/summary.json")
[ "$url_a" != "$url_b" ] || fail "both runs on one bus: $url_a"

# 2. Two runs forced onto one bus: both fail loudly, saying what to do.
URL="udpm://239.255.76.67:7681?ttl=0&recv_buf_size=4194304"
run c --lcm-url "$URL" & sleep 1; run d --lcm-url "$URL" & wait
for r in c d; do
  s="$WORK/$r/summary.json"
  [ "$(cat "$WORK/$r.rc")" != 0 ] || { tail -n 20 "$WORK/$r.out"; fail "run $r shared its bus, yet exit 0"; }
  grep -q '"status": "failed"' "$s" || { cat "$s"; fail "run $r: shared bus, status not failed"; }
  grep -q '"error": "another session is on this bus[^"]*leave out --lcm-url' "$s" ||
    { grep '"error"' "$s"; fail "run $r: the error does not name the other session and the fix"; }
  grep -q '"foreign_processes"' "$s" || fail "run $r: foreign processes not listed in summary.json"
done
# 3. Another session's frames alone on a live run's bus (its sensors log played in, no foreign process to hear): the
#    frames carry that session's id, the run's processes refuse them (counted) and the run fails loudly.
"$SRC/objscan" log filter "$WORK/a/session.lcmlog" "$WORK/a_sensors.lcmlog" --sensors > /dev/null
URL3="udpm://239.255.76.67:7683?ttl=0&recv_buf_size=4194304"
( while [ ! -f "$WORK/e.rc" ]; do
    in_ns "$NS" lcm-logplayer -l "$URL3" "$WORK/a_sensors.lcmlog" >> "$WORK/player.out" 2>&1 || sleep 0.2
  done ) &
player=$!
run e --lcm-url "$URL3" --frames 150  # long enough to overlap a replay of a's log whatever the start-up times
wait "$player"
s="$WORK/e/summary.json"
[ "$(cat "$WORK/e.rc")" != 0 ] || { tail -n 20 "$WORK/e.out"; tail -n 5 "$WORK/player.out"; grep -h "foreign" "$WORK/e/logs/"*.log | head -5
  fail "run e took in another session's frames, yet exit 0"; }
grep -q '"status": "failed"' "$s" || { cat "$s"; fail "run e: foreign frames, status not failed"; }
grep -q '"error": "another session is on this bus[^"]*inputs stamped with another session' "$s" ||
  { grep '"error"' "$s"; fail "run e: the error does not say that another session's frames were refused"; }
grep -q 'foreign session' "$s" || fail "run e: no 'foreign session' rejections counted in summary.json"
grep -q "another session is on this bus: [a-z_]* of session [0-9a-f]\{16\} refused" "$WORK/e/logs/"*.log ||
  fail "run e: no process log names the foreign session"
echo "PASS: two runs at once on their own buses as alone; two on one bus both failed loudly; another session's" \
  "frames played onto a live bus refused and the run failed loudly"
