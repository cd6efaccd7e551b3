#!/usr/bin/env bash
# Sessions that never hear each other (issue 26), in a private multicast namespace:
# 1. two `objscan run --sim --orbit` started together without --lcm-url: each picks a bus of its own (summary.json
#    "lcm_url" differs), each ends "ok" with exactly its frames, hears no foreign process, and poses its orbit as a run
#    alone does (registered fraction and ATE against its own truth);
# 2. two runs forced onto one URL: each hears the other's processes, ends at once with a non-zero exit, status
#    "failed" and an error that says what to do (a bus of its own).
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
echo "PASS: two runs at once on their own buses as alone; two on one bus both failed loudly"
