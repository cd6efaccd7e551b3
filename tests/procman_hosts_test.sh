#!/usr/bin/env bash
# procman across two hosts (issue 26): namespaces "robot" and "workstation" joined by veth, LCM udpm ttl=1, one
# objscan-deputy in each, the sheriff on the workstation. Checks, with figures printed:
# 1. the sheriff's script starts every process on its host, in order (sleeper waits for the tracker's PROCESS_STATUS);
# 2. kill -9 of the tracker (respawn = true): its deputy restarts it (time printed, <= 2 s plus the report period);
#    a crashing process without respawn is shown crashed with its exit code, and its output was captured;
# 3. orders from a sheriff with another config are refused by the deputies and counted; a deputy of another config
#    is shown FOREIGN;
# 4. a killed deputy is shown SILENT within 3 s; its processes do not outlive it;
# 5. stop all ends every process; bad configs and command lines exit 2 with the line and what is wrong.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
ROBOT=$(netns_name pmrobot); WS=$(netns_name pmws)
netns_create_pair "$ROBOT" "$WS" "10.232.$(( $$ % 200 + 1 ))"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
PORT=$(( 7800 + $$ % 100 ))
URL="udpm://239.255.76.67:$PORT?ttl=1&recv_buf_size=4194304"

cat > "$WORK/system.cfg" <<EOF
group robot
process tracker
  host = robot
  command = \${BIN}/tracker --lcm-url \${LCM_URL}
  respawn = true
group workstation
process sleeper
  host = workstation
  command = sleep 600
  after = tracker
process crasher
  host = workstation
  command = sh -c 'echo "crasher says hello"; exit 3'
EOF
sed 's/^group robot/# another config\ngroup robot/' "$WORK/system.cfg" > "$WORK/other.cfg"

deputy() {  # NS HOST CONFIG LOGDIR
  in_ns "$1" "$BIN/objscan-deputy" --config "$3" --host "$2" --lcm-url "$URL" --log-dir "$4" \
    BIN="$BIN" LCM_URL="$URL" > "$4.out" 2>&1 &
}
sheriff() {  # NS CONFIG ARGS...
  local ns="$1" cfg="$2"; shift 2
  in_ns "$ns" "$BIN/objscan-sheriff" "$cfg" --lcm-url "$URL" "$@"
}
line_of() { awk -v p="$1" '$1==p' "$2"; }

# 5a. Bad configs and command lines: exit 2, the line and what is wrong.
printf 'process a\n  host = robot\n  comand = x\n' > "$WORK/bad.cfg"
rc=0; "$BIN/objscan-deputy" --config "$WORK/bad.cfg" --host robot > "$WORK/bad.out" 2>&1 || rc=$?
[ $rc = 2 ] && grep -q "bad.cfg:3: unknown key 'comand'" "$WORK/bad.out" || { cat "$WORK/bad.out"; fail "bad config: exit $rc"; }
rc=0; "$BIN/objscan-deputy" --config "$WORK/system.cfg" --host robot > "$WORK/novar.out" 2>&1 || rc=$?
[ $rc = 2 ] && grep -q 'uses ${BIN}' "$WORK/novar.out" || { cat "$WORK/novar.out"; fail "undefined variable: exit $rc"; }
rc=0; "$BIN/objscan-deputy" --config "$WORK/system.cfg" --host laptop BIN=/b LCM_URL=u > "$WORK/nohost.out" 2>&1 || rc=$?
[ $rc = 2 ] && grep -q "no process for host 'laptop'" "$WORK/nohost.out" || { cat "$WORK/nohost.out"; fail "unknown host: exit $rc"; }
rc=0; "$BIN/objscan-sheriff" "$WORK/system.cfg" --script "start all; wiat-running all" > "$WORK/badscript.out" 2>&1 || rc=$?
[ $rc = 2 ] && grep -q "script step ' wiat-running all'" "$WORK/badscript.out" || { cat "$WORK/badscript.out"; fail "bad script: exit $rc"; }
echo "bad configs, variables, hosts and scripts: exit 2 with the reason"

# 1. Start in order.
deputy "$ROBOT" robot "$WORK/system.cfg" "$WORK/robot"
deputy "$WS" workstation "$WORK/system.cfg" "$WORK/ws"
sheriff "$WS" "$WORK/system.cfg" --script "start all; wait-running tracker 15; wait-status tracker 15; wait-running sleeper 10; wait-exit crasher 10" \
  > "$WORK/start.out" 2>&1 || { cat "$WORK/start.out" "$WORK/robot.out" "$WORK/ws.out"; fail "start script failed"; }
sheriff "$WS" "$WORK/system.cfg" --status > "$WORK/status1.txt" 2>&1
cat "$WORK/status1.txt"
line_of tracker "$WORK/status1.txt" | grep -q running || fail "tracker not running on robot"
line_of sleeper "$WORK/status1.txt" | grep -q running || fail "sleeper not running on workstation"
line_of crasher "$WORK/status1.txt" | grep -q "crashed.*exited with code 3" || fail "crasher not shown crashed with code 3"
grep -q "crasher says hello" "$WORK/ws/crasher.log" || fail "the crasher's output was not captured"
grep -q "deputies:  robot ok  workstation ok" "$WORK/status1.txt" || fail "deputies not both ok"

# 2. kill -9 the tracker: respawned.
pid=$(line_of tracker "$WORK/status1.txt" | awk '{print $6}')
kill -9 "$pid"
t0=$(date +%s.%N)
for _ in $(seq 1 100); do
  newpid=$(in_ns "$ROBOT" pgrep -f "^$BIN/tracker --lcm-url" || true)
  [ -n "$newpid" ] && [ "$newpid" != "$pid" ] && break
  sleep 0.05
done
t1=$(date +%s.%N)
[ -n "$newpid" ] && [ "$newpid" != "$pid" ] || fail "the tracker was not restarted"
echo "tracker killed (pid $pid), restarted as pid $newpid after $(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.2f", b-a}') s"
awk -v a="$t0" -v b="$t1" 'BEGIN{exit !(b - a <= 2.0)}' || fail "restart took more than 2 s"
sheriff "$WS" "$WORK/system.cfg" --status > "$WORK/status2.txt" 2>&1
line_of tracker "$WORK/status2.txt" | awk '{exit !($9 == 1)}' || { cat "$WORK/status2.txt"; fail "restarts not 1"; }

# 3. Another config's sheriff: refused and counted; another config's deputy: FOREIGN.
sheriff "$WS" "$WORK/other.cfg" --script "start sleeper; sleep 2" > "$WORK/other.out" 2>&1 || true
in_ns "$WS" "$BIN/objscan-deputy" --config "$WORK/other.cfg" --host robot --lcm-url "$URL" \
  --log-dir "$WORK/other" BIN="$BIN" LCM_URL="$URL" > "$WORK/other_deputy.out" 2>&1 &
OTHER=$!
sleep 0.5
sheriff "$WS" "$WORK/system.cfg" --status > "$WORK/status3.txt" 2>&1 || true
kill -TERM $OTHER 2>/dev/null || true
cat "$WORK/status3.txt"
grep -q "workstation ok (refused [1-9][0-9]*: orders from .* are for config" "$WORK/status3.txt" || fail "foreign orders not refused"
grep -q "robot FOREIGN" "$WORK/status3.txt" || fail "foreign deputy not shown"
line_of sleeper "$WORK/status3.txt" | grep -q "running" || fail "refused orders changed the sleeper"

# 4. A killed deputy: SILENT within 3 s, its processes gone.
sleeper_pid=$(line_of sleeper "$WORK/status3.txt" | awk '{print $6}')
in_ns "$WS" pkill -9 -f "objscan-deputy --config $WORK/system.cfg --host workstation" || fail "no workstation deputy"
sleep 0.5
# (a zombie waiting for this machine's init to reap it counts as ended)
state=$(ps -o stat= -p "$sleeper_pid" 2>/dev/null || true)
[ -z "$state" ] || [[ "$state" == Z* ]] || fail "the sleeper (pid $sleeper_pid, state $state) outlived its deputy"
sheriff "$WS" "$WORK/system.cfg" --status --deputy-timeout 3 > "$WORK/status4.txt" 2>&1 || true
grep -q "workstation SILENT" "$WORK/status4.txt" || { cat "$WORK/status4.txt"; fail "a dead deputy not shown SILENT"; }
echo "a killed deputy: SILENT after 3 s, its processes ended with it"

# 5. Stop all.
sheriff "$WS" "$WORK/system.cfg" --script "stop all; wait-exit tracker 15" > "$WORK/stop.out" 2>&1 ||
  { cat "$WORK/stop.out"; fail "stop script failed"; }
in_ns "$ROBOT" pgrep -f "^$BIN/tracker --lcm-url" && fail "tracker still running after stop all"
echo "PASS"
