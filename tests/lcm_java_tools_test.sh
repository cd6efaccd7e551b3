#!/usr/bin/env bash
# LCM's Java tools as users run them, headless, in a private multicast namespace (issue 29):
# 1. What lcm-spy sees: LcmRateCheck counts with LCM's Java receiver (the one lcm.spy.Spy uses), started through
#    scripts/lcm-java as scripts/lcm-spy starts the spy, while the simulator publishes 150 RGB images at 30 Hz. At
#    least 95 % of the images must arrive. The same without the receive-buffer shim is printed for comparison.
# 2. scripts/lcm-logplayer-gui (objscan logplayer-gui) under xvfb-run plays a log onto the bus; every image of it is
#    counted on the bus.
# Exit 77 (skipped) without java, the type jar, namespaces or xvfb-run.
set -euo pipefail
BIN="$1"; SRC="$2"
BUILD="$(dirname "$BIN")"
CLASSES="$BUILD/viewer/spy_classes"
command -v java > /dev/null || { echo "SKIP: no java"; exit 77; }
[ -f "$CLASSES/LcmRateCheck.class" ] && [ -f "$BUILD/objscan_lcmtypes.jar" ] || { echo "SKIP: no Java classes built"; exit 77; }
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name javatools); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$BUILD"
FRAMES=150

# count FILE CHANNEL: the count LcmRateCheck printed for CHANNEL (0 when none).
count() { awk -v c="$2" '$1 == c {n = $2} END {print n + 0}' "$1"; }

# Waits (up to 20 s) until the Java receiver has joined the group.
wait_listening() {
  for _ in $(seq 1 200); do grep -q '^listening' "$1" 2> /dev/null && return 0; sleep 0.1; done
  cat "$1"; fail "the Java receiver did not start"
}

spy_images() {  # RCVBUF_BYTES OUT: images LcmRateCheck counts during a 150-frame 30 Hz run
  local url="udpm://239.255.76.67:7681?ttl=0&recv_buf_size=4194304"
  OBJSCAN_UDP_RCVBUF="$1" ip netns exec "$NS" "$SRC/scripts/lcm-java" --cp "$CLASSES" LcmRateCheck "$url" 10 \
    > "$2" 2>&1 &
  local checker=$!
  wait_listening "$2"
  ip netns exec "$NS" "$BIN/robot_sim" --lcm-url "$url" --scene "$SRC/drivers/robot_sim/scenes/sphere.scene" \
    --frames $FRAMES --orbit-radius 800 > "$WORK/sim.out" 2>&1 || { cat "$WORK/sim.out"; fail "robot_sim failed"; }
  wait $checker || { cat "$2"; fail "LcmRateCheck failed"; }
}

spy_images 0 "$WORK/plain.txt"
spy_images 4194304 "$WORK/shim.txt"
plain=$(count "$WORK/plain.txt" CAMERA_IMAGE)
shim=$(count "$WORK/shim.txt" CAMERA_IMAGE)
odometry=$(count "$WORK/shim.txt" ROBOT_ODOMETRY)
echo "images seen by LCM's Java receiver, of $FRAMES at 30 Hz (640x480 RGB): $plain with the system's default socket buffer, $shim through scripts/lcm-java"
[ "$odometry" -ge $((FRAMES * 95 / 100)) ] || { cat "$WORK/shim.txt"; fail "only $odometry of $FRAMES odometry messages"; }
[ "$shim" -ge $((FRAMES * 95 / 100)) ] || { cat "$WORK/shim.txt"; fail "lcm-spy's receiver saw $shim of $FRAMES images (< 95 %)"; }

if command -v xvfb-run > /dev/null; then
  "$SRC/objscan" make-test-log --out "$WORK/test.lcmlog" > /dev/null
  url="udpm://239.255.76.67:7682?ttl=0&recv_buf_size=4194304"
  ip netns exec "$NS" "$SRC/scripts/lcm-java" --cp "$CLASSES" LcmRateCheck "$url" 12 > "$WORK/gui.txt" 2>&1 &
  checker=$!
  wait_listening "$WORK/gui.txt"
  # LCM's player starts playing at once (unless --paused); it is a GUI and never exits by itself.
  ip netns exec "$NS" setsid xvfb-run -a -s "-screen 0 1280x800x24" "$SRC/objscan" logplayer-gui --lcm-url="$url" \
    "$WORK/test.lcmlog" > "$WORK/player.out" 2>&1 &
  player=$!
  wait $checker || { cat "$WORK/gui.txt"; fail "LcmRateCheck failed"; }
  kill -0 $player 2> /dev/null || { cat "$WORK/player.out"; fail "objscan logplayer-gui exited early"; }
  kill -TERM -- "-$player" 2> /dev/null || true
  wait $player 2> /dev/null || true
  played=$(count "$WORK/gui.txt" CAMERA_IMAGE)
  logged=$("$BIN/objscan_logtool" count "$WORK/test.lcmlog" | awk '$1 == "CAMERA_IMAGE" {print $2}')
  echo "objscan logplayer-gui: $played of $logged images of the log on the bus"
  [ "$played" -ge $((logged * 95 / 100)) ] || { cat "$WORK/player.out" "$WORK/gui.txt"; fail "the log player GUI played $played of $logged images"; }
else
  echo "xvfb-run missing: objscan logplayer-gui not checked"
fi
echo "PASS: LCM's Java receiver sees $shim of $FRAMES images through scripts/lcm-java"
