#!/usr/bin/env bash
# Robot and workstation as two hosts: two network namespaces joined by a veth pair, LCM udpm with ttl=1.
# The simulated robot runs on "robot"; the tracker and lcm-logger run on "workstation". Every frame must cross
# and be tracked.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
ROBOT=$(netns_name robot); WS=$(netns_name ws)
netns_create_pair "$ROBOT" "$WS" "10.231.$(( $$ % 200 + 1 ))"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
URL="udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304"
FRAMES=30

ip netns exec "$WS" lcm-logger --lcm-url="$URL" --flush-interval=100 -f "$WORK/ws.lcmlog" > "$WORK/logger.out" 2>&1 &
LOGGER=$!
ip netns exec "$WS" "$BIN/tracker" --lcm-url "$URL" > "$WORK/tracker.out" 2>&1 &
TRACKER=$!
sleep 1.0
in_ns "$ROBOT" "$BIN/robot_sim" --lcm-url "$URL" --scene "$SRC/drivers/robot_sim/scenes/sphere.scene" \
  --frames $FRAMES --realtime=true --lockstep-channel FEATURE_TRACKS > "$WORK/sim.out" 2>&1 \
  || { cat "$WORK/sim.out"; fail "robot_sim failed"; }
for _ in $(seq 1 100); do kill -0 $TRACKER 2>/dev/null || break; sleep 0.1; done
kill -TERM $TRACKER 2>/dev/null || true; wait $TRACKER || true
sleep 1.0
kill -TERM $LOGGER; wait $LOGGER || true
"$BIN/objscan_logtool" count "$WORK/ws.lcmlog" | tee "$WORK/count.txt"
for ch in CAMERA_IMAGE FEATURE_TRACKS; do
  n=$(awk -v c=$ch '$1==c {print $2}' "$WORK/count.txt")
  [ "${n:-0}" -eq $FRAMES ] || fail "$ch: $n of $FRAMES on the workstation"
done
echo "PASS: $FRAMES frames crossed robot -> workstation and were tracked"
