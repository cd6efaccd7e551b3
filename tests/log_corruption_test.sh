#!/usr/bin/env bash
# Broken logs (issue 28): a log cut inside an event and one with 4 KB of garbage spliced in are replayed up to and past
# the damage, with the damage named and exit 3; an empty file and a PNG are refused (exit 1); an intact log exits 0.
set -euo pipefail
BIN="$1"; SRC="$2"
fail() { echo "FAIL: $*"; exit 1; }
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
LOG="$SRC/logs/sim_sphere_60.lcmlog"
[ -s "$LOG" ] || fail "no $LOG"
size=$(stat -c %s "$LOG")
head -c $((size / 2)) "$LOG" > "$WORK/cut.lcmlog"
{ head -c $((size / 3)) "$LOG"; head -c 4096 /dev/urandom; tail -c +$((size / 3 + 1)) "$LOG"; } > "$WORK/spliced.lcmlog"
: > "$WORK/empty.lcmlog"
printf '\x89PNG\r\n\x1a\n\0\0\0\rIHDR' > "$WORK/image.png"

replay() {  # NAME LOG: exit code in RC, output in $WORK/NAME.out
  RC=0; "$BIN/objscan_replay" --log "$2" --out "$WORK/$1" --tracker-only > "$WORK/$1.out" 2>&1 || RC=$?
}
events() { grep -o 'nodes [a-z_,]*: [0-9]* log events' "$WORK/$1.out" | awk '{print $3}'; }

replay intact "$LOG"
[ "$RC" = 0 ] || { cat "$WORK/intact.out"; fail "intact log: exit $RC"; }
replay spliced "$WORK/spliced.lcmlog"
[ "$RC" = 3 ] || { cat "$WORK/spliced.out"; fail "spliced log: exit $RC, expected 3"; }
grep -q "the log is damaged: .* bytes in 1 region" "$WORK/spliced.out" || { cat "$WORK/spliced.out"; fail "spliced: no damage message"; }
[ "$(events spliced)" = "$(events intact)" ] || fail "spliced: $(events spliced) events read, intact $(events intact)"
replay cut "$WORK/cut.lcmlog"
[ "$RC" = 3 ] || { cat "$WORK/cut.out"; fail "cut log: exit $RC, expected 3"; }
grep -q "the last event is cut short" "$WORK/cut.out" || { cat "$WORK/cut.out"; fail "cut: no damage message"; }
[ "$(events cut)" -gt 0 ] || fail "cut: nothing read before the cut"
replay empty "$WORK/empty.lcmlog"
[ "$RC" = 1 ] && grep -q "is empty: not an LCM log" "$WORK/empty.out" || { cat "$WORK/empty.out"; fail "empty file not refused"; }
replay png "$WORK/image.png"
[ "$RC" = 1 ] && grep -q "is not an LCM log" "$WORK/png.out" || { cat "$WORK/png.out"; fail "PNG not refused"; }
echo "PASS: broken logs are read past their damage with exit 3; files that are no log are refused"
