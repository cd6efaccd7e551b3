#!/usr/bin/env bash
# lcm-logger keeps every message of a run: the simulated robot publishes N frames in real time on a private
# multicast bus; lcm-logger (stopped only after the publisher exits and a flush interval passes) must hold every
# message, counted per channel.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name logger); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
FRAMES=45

ip netns exec "$NS" lcm-logger --lcm-url="$URL" --flush-interval=100 -f "$WORK/run.lcmlog" > "$WORK/logger.out" 2>&1 &
LOGGER=$!
sleep 0.5
in_ns "$NS" "$BIN/robot_sim" --lcm-url "$URL" --scene "$SRC/drivers/robot_sim/scenes/sphere.scene" \
  --frames $FRAMES --realtime=true > "$WORK/sim.out" 2>&1 || { cat "$WORK/sim.out"; fail "robot_sim failed"; }
sleep 1.5   # flush interval x 15 after the publisher stopped
kill -TERM $LOGGER; wait $LOGGER || true

"$BIN/objscan_logtool" count "$WORK/run.lcmlog" | tee "$WORK/count.txt"
for ch in CAMERA_IMAGE CAMERA_INFO ROBOT_ODOMETRY GROUND_TRUTH_POSE; do
  n=$(awk -v c=$ch '$1==c {print $2}' "$WORK/count.txt")
  [ "${n:-0}" -eq $FRAMES ] || fail "$ch: logged ${n:-0} of $FRAMES messages"
done
n=$(awk '$1=="OBJSCAN_CONTROL" {print $2}' "$WORK/count.txt")
[ "${n:-0}" -ge 1 ] || fail "END_OF_STREAM not logged"
echo "PASS: lcm-logger kept all $FRAMES frames on every channel"
