#!/usr/bin/env bash
# End to end through the user's launcher, in a private multicast namespace: `objscan run --sim` starts every
# process on a live udpm bus, logs the session, stops on its own and writes summary.json; and
# `objscan run --dataset` does the same on a real image set (Middlebury templeSparseRing).
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name session); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
FRAMES=40

check_summary() {  # DIR FRAMES
  local s="$1/summary.json"
  [ -f "$s" ] || fail "no $s"
  grep -q '"status": "ok"' "$s" || { cat "$s"; fail "session status not ok"; }
  grep -q '"complete": true' "$s" || { cat "$s"; fail "session log incomplete"; }
  grep -q "\"frames\": $2," "$s" || { cat "$s"; fail "expected $2 frames"; }
  [ -s "$1/session.lcmlog" ] || fail "no session log"
}

in_ns "$NS" "$SRC/objscan" run --sim --scene sphere --frames $FRAMES --out "$WORK/sim" --lcm-url "$URL" \
  || { tail -n 30 "$WORK"/sim/logs/*.log; fail "objscan run --sim failed"; }
check_summary "$WORK/sim" $FRAMES
[ -s "$WORK/sim/ground_truth/poses_gt.txt" ] || fail "no ground truth written"

DATA="${OBJSCAN_DATA_DIR:-$SRC/../shared/data}/middlebury_templeSparseRing"
if [ -d "$DATA" ]; then
  in_ns "$NS" "$SRC/objscan" run --dataset "$DATA" --out "$WORK/temple" --lcm-url "$URL" \
    || { tail -n 30 "$WORK"/temple/logs/*.log; fail "objscan run --dataset failed"; }
  check_summary "$WORK/temple" 16
  # Wide-baseline profile (descriptor tracks, two-view fallback) in ring order: most views get a pose, which the KLT
  # chain above cannot give (measured 11 of 15; views before the start span stay unposed).
  in_ns "$NS" "$SRC/objscan" run --dataset "$DATA" --out "$WORK/temple_wide" --lcm-url "$URL" --wide-baseline \
    --order "9,8,7,6,15,16,12,13,5,4,3,14,2,1,10" \
    || { tail -n 30 "$WORK"/temple_wide/logs/*.log; fail "objscan run --dataset --wide-baseline failed"; }
  check_summary "$WORK/temple_wide" 15
  posed=$(grep -vc '^#' "$WORK/temple_wide/trajectory.txt" || true)
  [ "${posed:-0}" -ge 10 ] || fail "wide baseline: only ${posed:-0} of 15 views posed"
  echo "wide baseline: $posed of 15 temple views posed"
fi
echo "PASS: objscan run --sim and --dataset ran to the end, logged every message and wrote summaries"
