#!/usr/bin/env bash
# Issue 28's fuzz test, in a private multicast namespace: the simulated orbit (`objscan run --sim --orbit`, 120 frames) runs
# once clean and once while objscan_bus_fuzz publishes hostile messages on every input channel of every process
# (random bytes, a fingerprint then garbage, truncated messages, array counts of -1 / 2^25 / 2^31-1, NaN / inf
# fields, forged sequence numbers, duplicate ids; 150 per second for the whole run). Checks: the fuzzed session ends
# by itself with status ok and exit 0 (no crash, no stall: CTest's timeout), the processes counted rejections, the
# supervisor counted malformed messages and no more frames than were sent, and the model is within 2x the clean
# run's mesh p90 and completeness, and each process's peak resident memory (summary.json, from wait4) is under 2x the
# clean run's (+ 20 MB for the small ones).
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name fuzz); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
URL="udpm://239.255.76.67:7673?ttl=0&recv_buf_size=4194304"
FRAMES=120

run() {  # NAME
  in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames $FRAMES --out "$WORK/$1" --lcm-url "$URL" \
    > "$WORK/$1.out" 2>&1
}
mesh() {  # NAME FIELD(p90|completeness)
  awk -v f="$2" '/model_mesh +vs truth/ {for (i = 1; i <= NF; ++i) if ($i == f) {gsub(/[%,]/, "", $(i + 1)); print $(i + 1)}}' \
    "$WORK/$1.out" | head -n 1
}

run clean || { tail -n 20 "$WORK/clean.out"; fail "the clean run failed"; }
in_ns "$NS" "$BIN/objscan_bus_fuzz" --lcm-url "$URL" --seconds 25 --rate 150 --seed 7 > "$WORK/fuzz.out" 2>&1 &
fuzz_pid=$!
rc=0
run fuzzed || rc=$?
wait "$fuzz_pid" || true
cat "$WORK/fuzz.out"
tail -n 8 "$WORK/fuzzed.out"
[ "$rc" = 0 ] || fail "the fuzzed run exited $rc"
S="$WORK/fuzzed/summary.json"
grep -q '"status": "ok"' "$S" || fail "fuzzed session status not ok"
grep -q "\"frames\": $FRAMES," "$S" || { grep '"frames"' "$S"; fail "the fuzzed run did not count exactly $FRAMES frames"; }
rejected=$(grep -o '"messages_rejected": [0-9]*' "$S" | awk '{s += $2} END {print s + 0}')
malformed=$(grep -o '"malformed": [0-9]*' "$S" | awk '{s += $2} END {print s + 0}')
echo "rejected by the processes: $rejected, malformed counted by the supervisor: $malformed"
[ "$rejected" -gt 100 ] || fail "the processes rejected only $rejected hostile messages"
[ "$malformed" -gt 100 ] || fail "the supervisor counted only $malformed malformed messages"
p90_clean=$(mesh clean p90); p90_fuzzed=$(mesh fuzzed p90)
comp_clean=$(mesh clean completeness); comp_fuzzed=$(mesh fuzzed completeness)
echo "mesh p90 clean $p90_clean mm, fuzzed $p90_fuzzed mm; completeness clean $comp_clean %, fuzzed $comp_fuzzed %"
[ -n "$p90_clean" ] && [ -n "$p90_fuzzed" ] || fail "no mesh figures"
awk -v a="$p90_fuzzed" -v b="$p90_clean" 'BEGIN {exit !(a <= 2 * b + 0.05)}' || fail "fuzzed mesh p90 more than 2x clean"
awk -v a="$comp_fuzzed" -v b="$comp_clean" 'BEGIN {exit !(2 * a >= b)}' || fail "fuzzed completeness under half of clean"
peaks() {  # NAME: "process peak_rss_mb" lines from summary.json
  awk '/^    "[a-z_]+": \{/ {name = $1; gsub(/[":{ ]/, "", name)} /"peak_rss_mb":/ {v = $2; gsub(/,/, "", v); print name, v}' \
    "$WORK/$1/summary.json" | sort
}
peaks clean > "$WORK/clean.rss"; peaks fuzzed > "$WORK/fuzzed.rss"
[ -s "$WORK/clean.rss" ] || fail "no peak_rss_mb in the clean summary"
join "$WORK/clean.rss" "$WORK/fuzzed.rss" | awk '{printf "peak RSS %-14s clean %7.1f MB, fuzzed %7.1f MB\n", $1, $2, $3;
  if ($3 > 2 * $2 + 20) bad = bad " " $1} END {if (bad != "") {print "over 2x the clean run:" bad; exit 1}}' \
  || fail "a process's peak memory under fire is more than 2x the clean run's"
echo "PASS: $FRAMES frames under fire: no crash, no stall, hostile messages counted, the model and memory within 2x"
