#!/usr/bin/env bash
# ctest "spy": scripts/lcm-spy starts lcm.spy.Spy with the objscan types under xvfb-run on memq:// and is still
# running after 5 s (then it is stopped). Exit 77 (skipped) without java or xvfb-run.
# Usage: spy_gui_test.sh LCM_SPY_SCRIPT BUILD_DIR
set -u
spy=$1 build=$2
command -v java > /dev/null 2>&1 || { echo "java not installed: skipped"; exit 77; }
command -v xvfb-run > /dev/null 2>&1 || { echo "xvfb-run not installed: skipped"; exit 77; }
out=$(mktemp "${TMPDIR:-/tmp}/objscan_spy_gui.XXXXXX")
trap 'rm -f "$out"' EXIT
OBJSCAN_BUILD_DIR="$build" setsid xvfb-run -a -s "-screen 0 1280x800x24" bash "$spy" --lcm-url=memq:// > "$out" 2>&1 &
pid=$!
alive=1
for _ in $(seq 1 50); do
  sleep 0.1
  kill -0 "$pid" 2> /dev/null || { alive=0; break; }
done
if [ "$alive" = 1 ]; then
  kill -TERM -- "-$pid" 2> /dev/null
  wait "$pid" 2> /dev/null
  echo "--- spy output"; cat "$out"
  # Spy prints how many LCM types it found on the class path: all 12 objscan types must be there.
  found=$(sed -n 's/^Found \([0-9]*\) LCM types.*/\1/p' "$out" | head -1)
  if [ -z "$found" ] || [ "$found" -lt 12 ]; then
    echo "FAIL: spy did not find the objscan types (found '${found}')"
    exit 1
  fi
  echo "PASS: spy stayed up for 5 s with $found LCM types"
  exit 0
fi
wait "$pid"
echo "FAIL: spy exited with $? before 5 s"; cat "$out"
exit 1
