#!/usr/bin/env bash
# Runs the closed loop (objscan run --sim --closed-loop) on the simulator's rooms and writes the table of figures
# (issue 24) to stdout and to OUT/rooms.md: per room the target, the outcome, when it was confirmed, the centre
# error against the truth (after the trajectory's Sim(3)), collisions, path, frames, wall time, and the model against
# the target's whole surface above 10 mm, aligned on the whole trajectory (the issue's figure) and on the modeling
# segment alone. Usage: scripts/rooms_table.sh [--score-only] [--keep-logs] [--circle] [OUT [ROOM...]] (default out/rooms, all
# 10); --score-only scores the runs already in OUT again without running them (default: every room_* in OUT); each room's session.lcmlog (4-6 GB)
# is deleted once the room is scored (its report.html is written already) unless --keep-logs.
# --circle: the plain circle (objscan run --next-views 0), for the next-best-view comparison.
# Each room runs live in its own network namespace (root), as fast as the pipeline goes (--fast), 9000-frame budget.
set -uo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
SCORE_ONLY=0 KEEP_LOGS=0 RUN_EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    --score-only) SCORE_ONLY=1; shift ;;
    --keep-logs) KEEP_LOGS=1; shift ;;
    --circle) RUN_EXTRA=(--next-views 0); shift ;;
    -*) echo "rooms_table.sh: unknown option $1 (usage: [--score-only] [--keep-logs] [--circle] [OUT [ROOM...]])" >&2; exit 2 ;;
    *) break ;;
  esac
done
OUT="${1:-$ROOT/out/rooms}"; shift || true
ROOMS=("$@")
if [ ${#ROOMS[@]} -eq 0 ] && [ "$SCORE_ONLY" = 1 ]; then  # the rooms run into OUT already
  ROOMS=($(cd "$OUT" 2>/dev/null && ls -d room_*/ 2>/dev/null | tr -d /))
  [ ${#ROOMS[@]} -gt 0 ] || { echo "rooms_table.sh: no room_* runs in $OUT to score" >&2; exit 1; }
fi
[ ${#ROOMS[@]} -gt 0 ] || ROOMS=($(cd "$ROOT/drivers/robot_sim/scenes/rooms" && ls room_*.scene | sed 's/\.scene$//'))
BIN="${OBJSCAN_BUILD_DIR:-$ROOT/build}/bin"
mkdir -p "$OUT"
value() { awk -v k="$1" '$1==k {print $2}'; }
json_number() { tr -d '\n' < "$2" | grep -o "\"$1\": *-\?[0-9.e+-]*" | head -1 | sed 's/.*: *//'; }
table="$OUT/rooms.md"
{
  echo "| room | target | outcome | confirmed at frame | centre error mm | collisions | path m | frames | wall s | mesh p90 mm | mesh max mm | completeness (z > 10 mm) | model frames | centre error mm (model frames) | mesh p90 / max mm, completeness (model frames) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$table"

# The modeling segment of a run (DIR): final poses from the frame the target was confirmed at (or from the start of
# the map the dense modeler kept, when it kept one of several maps never joined and that map began later) up to the
# pose solver's next map restart, if any (a restarted map that was not joined lies in another frame). The issue's
# figures align the whole trajectory to the truth; the segment's own alignment shows the model apart from the
# exploration's drift. Prints the segment's TUM file and its frame range.
model_segment() {
  local d="$1" seg="$1/.model_segment.txt" c t0 restart t1 kept
  c=$(json_number confirmed_seq "$d/target.json" 2>/dev/null); c=${c:--1}
  [ "$c" -ge 0 ] || return 1
  kept=$(grep -o 'keeps the map that began at frame [0-9]*' "$d/logs/dense_modeler.log" 2>/dev/null | awk '{print $NF}' | tail -1)
  [ -n "$kept" ] && [ "$kept" -gt "$c" ] && c=$kept
  restart=$(grep -o 'initialized on frames [0-9]*' "$d/logs/pose_solver.log" 2>/dev/null | awk -v c="$c" '$4 > c {print $4; exit}')
  t0=$(awk -v k="$c" '!/^#/ {if (n++ == k) {print $1; exit}}' "$d/ground_truth/poses_gt.txt")
  t1=$( [ -n "$restart" ] && awk -v k="$restart" '!/^#/ {if (n++ == k) {print $1; exit}}' "$d/ground_truth/poses_gt.txt")
  awk -v t0="$t0" -v t1="${t1:-1e300}" '/^#/ || ($1 >= t0 && $1 < t1)' "$d/trajectory.txt" > "$seg"
  echo "$seg $c..${restart:-end}"
}

# score ROOM WALL_S: one row of the table from OUT/ROOM.
score() {
  local room="$1" wall="$2" d="$OUT/$1" shape outcome confirmed collisions path frames err p90 mx comp seg range
  local serr="-" smodel="-" e
  shape=$(tr -d '\n' < "$d/ground_truth/sim_outcome.json" 2>/dev/null | grep -o '"shape": *"[a-z]*"' | sed 's/.*"\([a-z]*\)"$/\1/')
  outcome=$(tr -d '\n' < "$d/plan.json" 2>/dev/null | grep -o '"outcome": *"[a-z_]*"' | sed 's/.*"\([a-z_]*\)"$/\1/')
  confirmed=$(json_number confirmed_seq "$d/target.json" 2>/dev/null)
  collisions=$(json_number collisions "$d/ground_truth/sim_outcome.json" 2>/dev/null)
  path=$(awk -v p="$(json_number path_length_mm "$d/ground_truth/sim_outcome.json" 2>/dev/null)" 'BEGIN{printf "%.1f", p/1000}')
  frames=$(json_number frames "$d/ground_truth/sim_outcome.json" 2>/dev/null)
  err="-"; p90="-"; mx="-"; comp="-"; range="-"
  local confirmed_target=0
  grep -Eq '"state": "(confirmed|lost)"' "$d/target.json" 2>/dev/null && confirmed_target=1
  [ -s "$d/trajectory.txt" ] || confirmed_target=0
  if [ "$confirmed_target" = 1 ]; then
    local mesh_arg=()  # the true box along the estimate's yaw (TrueBoxAtYaw)
    [ -s "$d/ground_truth/target_mesh.ply" ] && mesh_arg=(--truth-mesh "$d/ground_truth/target_mesh.ply")
    err=$("$BIN/objscan_evaluate" target "$d/target.json" "$d/ground_truth/sim_outcome.json" "${mesh_arg[@]}" \
          --align "$d/trajectory.txt" "$d/ground_truth/poses_gt.txt" 2>/dev/null | value center_error_mm)
    if read -r seg range < <(model_segment "$d"); then
      serr=$("$BIN/objscan_evaluate" target "$d/target.json" "$d/ground_truth/sim_outcome.json" "${mesh_arg[@]}" \
            --align "$seg" "$d/ground_truth/poses_gt.txt" 2>/dev/null | value center_error_mm)
    fi
  fi
  if [ -s "$d/model_mesh.ply" ] && [ -s "$d/trajectory.txt" ]; then
    for align in whole segment; do
      local a="$d/trajectory.txt"
      if [ "$align" = segment ]; then [ -n "${seg:-}" ] || continue; a="$seg"; fi
      e=$("$BIN/objscan_evaluate" surface "$d/model_mesh.ply" "$d/ground_truth/target_surface.ply" \
          --truth-mesh "$d/ground_truth/target_mesh.ply" --align "$a" "$d/ground_truth/poses_gt.txt" \
          --min-z 10 2>/dev/null)
      [ "$(echo "$e" | value model_points)" != 0 ] || continue
      if [ "$align" = whole ]; then
        p90=$(echo "$e" | value accuracy_p90); mx=$(echo "$e" | value accuracy_max); comp=$(echo "$e" | value completeness)
      else
        smodel="$(echo "$e" | value accuracy_p90) / $(echo "$e" | value accuracy_max), $(echo "$e" | value completeness)"
      fi
    done
  fi
  row="| $room | ${shape:--} | ${outcome:-none} | ${confirmed:--} | ${err:--} | ${collisions:--} | $path | ${frames:--} | $wall | $p90 | $mx | $comp | $range | ${serr:--} | $smodel |"
  echo "$row" >> "$table"
  echo "$row"
}

port=7700
for room in "${ROOMS[@]}"; do
  port=$((port + 1))
  if [ "$SCORE_ONLY" = 1 ]; then
    score "$room" "$(awk '{printf "%.0f", $1}' "$OUT/$room/.wall_s" 2>/dev/null || echo -)"
    continue
  fi
  ns="objscan-rooms-$$-$port"
  ip netns add "$ns" && ip -n "$ns" link set lo up && ip -n "$ns" link set lo multicast on &&
    ip -n "$ns" route add 224.0.0.0/4 dev lo || { echo "cannot create a network namespace (root needed)"; exit 2; }
  d="$OUT/$room"; rm -rf "$d"
  start=$(date +%s)
  ip netns exec "$ns" "$ROOT/objscan" run --sim --closed-loop --scene "$room" --out "$d" --fast "${RUN_EXTRA[@]}" \
    --lcm-url "udpm://239.255.76.67:$port?ttl=0&recv_buf_size=4194304" > "$OUT/$room.out" 2>&1
  wall=$(( $(date +%s) - start ))
  ip netns delete "$ns"
  echo "$wall" > "$d/.wall_s"
  score "$room" "$wall"
  [ "$KEEP_LOGS" = 1 ] || rm -f "$d/session.lcmlog"
done
echo "table: $table"
