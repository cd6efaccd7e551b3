#!/usr/bin/env bash
# Signals and dying processes (issue 28): the launcher `objscan run` ends the session in order with results written
# on SIGTERM; when a process is killed the survivors still write what they have and the summary names the signal;
# when the launcher itself is killed with -9 the session notices, ends in order, and no process outlives it. A new
# run into the folder of an earlier one moves the earlier one aside; a folder of other files is refused untouched.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name signals); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
FRAMES=160

# start NAME PORT: the launcher in the background, output in $WORK/NAME.out; JOB is the background job (the
# namespace wrapper), LAUNCHER the `objscan run` process itself.
start() {
  local url="udpm://239.255.76.67:$2?ttl=0&recv_buf_size=4194304"
  in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames $FRAMES --out "$WORK/$1" --lcm-url "$url" \
    > "$WORK/$1.out" 2>&1 &
  JOB=$!
  local i
  for i in $(seq 100); do
    LAUNCHER=$(pgrep -o -f "objscan run --sim --orbit .* --out $WORK/$1 " || true)
    [ -n "$LAUNCHER" ] && return 0
    sleep 0.1
  done
  fail "$1: launcher not found"
}
# wait_frames NAME N: until the progress line shows frame N or more (60 s at most).
wait_frames() {
  local i
  for i in $(seq 600); do
    if grep -Eo "frame [0-9]+/" "$WORK/$1.out" 2>/dev/null | tr -dc '0-9\n' | awk -v n="$2" '$1 >= n {f=1} END {exit !f}'
    then return 0; fi
    sleep 0.1
  done
  cat "$WORK/$1.out"; fail "$1: frame $2 not reached"
}
# no_survivors PORT: no process of that session is left (10 s grace).
no_survivors() {
  local i
  for i in $(seq 100); do
    pgrep -f "239.255.76.67:$1" > /dev/null || return 0
    sleep 0.1
  done
  pgrep -af "239.255.76.67:$1"; fail "processes of the session on port $1 outlived it"
}
summary_has() {  # NAME PATTERN
  grep -q "$2" "$WORK/$1/summary.json" || { cat "$WORK/$1/summary.json"; fail "$1: summary.json lacks $2"; }
}
results_written() {  # NAME
  local f
  for f in trajectory.txt model_mesh.ply; do
    [ -s "$WORK/$1/$f" ] || { cat "$WORK/$1.out"; tail -n 20 "$WORK/$1"/logs/*.log; fail "$1: no $f written"; }
  done
  # The files themselves say they are partial, not only summary.json.
  sed -n 2p "$WORK/$1/trajectory.txt" | grep -q '^# partial: ' || { head -3 "$WORK/$1/trajectory.txt"; fail "$1: trajectory.txt not marked partial"; }
  grep -a -m1 -q '^comment partial: ' "$WORK/$1/model_mesh.ply" || fail "$1: model_mesh.ply not marked partial"
}

# 1. SIGTERM to the launcher: results, status "interrupted", exit 130.
start term 7691
wait_frames term 40
kill -TERM "$LAUNCHER"
rc=0; wait "$JOB" || rc=$?
[ "$rc" = 130 ] || { cat "$WORK/term.out"; fail "SIGTERM: launcher exit $rc, expected 130"; }
summary_has term '"status": "interrupted"'
summary_has term '"partial_results"'
results_written term
no_survivors 7691

# 2. kill -9 of the tracker: the session fails (exit 1) naming the signal; pose solver and dense modeler still write.
start kill9 7692
wait_frames kill9 40
pkill -9 -f "bin/tracker --lcm-url udpm://239.255.76.67:7692" || fail "no tracker to kill"
rc=0; wait "$JOB" || rc=$?
[ "$rc" = 1 ] || { cat "$WORK/kill9.out"; fail "tracker killed: launcher exit $rc, expected 1"; }
summary_has kill9 "'tracker' was killed by signal 9 (SIGKILL)"
summary_has kill9 '"partial_results"'
results_written kill9
no_survivors 7692

# 3. kill -9 of the launcher: the session still ends in order and writes its summary; nothing is left running.
start orphan 7693
wait_frames orphan 40
kill -9 "$LAUNCHER"
for i in $(seq 600); do
  grep -q '"status"' "$WORK/orphan/summary.json" 2>/dev/null && break
  sleep 0.1
done
no_survivors 7693
summary_has orphan '"status": "interrupted"'
results_written orphan

# 4. Output folders: the interrupted run of 1 is moved aside whole; a folder that is not an objscan output is refused.
size_before=$(stat -c %s "$WORK/term/session.lcmlog")
in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames 40 --out "$WORK/term" \
  --lcm-url "udpm://239.255.76.67:7694?ttl=0&recv_buf_size=4194304" > "$WORK/again.out" 2>&1 \
  || { cat "$WORK/again.out"; fail "run into an earlier run's folder failed"; }
grep -q "held an earlier run: moved it to $WORK/term.1" "$WORK/again.out" || { cat "$WORK/again.out"; fail "no move message"; }
[ "$(stat -c %s "$WORK/term.1/session.lcmlog")" = "$size_before" ] || fail "the earlier log was not kept whole"
grep -q '"status": "interrupted"' "$WORK/term.1/summary.json" || fail "the earlier summary was not kept"
grep -q '"status": "ok"' "$WORK/term/summary.json" || fail "the new run's summary is not in the folder"
mkdir -p "$WORK/mine"; echo keep > "$WORK/mine/notes.txt"
rc=0; in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames 20 --out "$WORK/mine" \
  --lcm-url "udpm://239.255.76.67:7695?ttl=0&recv_buf_size=4194304" > "$WORK/mine.out" 2>&1 || rc=$?
[ "$rc" != 0 ] || fail "a folder of other files was used as output"
grep -q "not an objscan output" "$WORK/mine.out" || { cat "$WORK/mine.out"; fail "no clear message for a foreign folder"; }
[ "$(ls "$WORK/mine")" = notes.txt ] && [ "$(cat "$WORK/mine/notes.txt")" = keep ] || fail "the foreign folder was touched"
echo "PASS: signals and output folders"
