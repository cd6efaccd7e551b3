#!/usr/bin/env bash
# Runs the closed loop (objscan run --sim --closed-loop) on the simulator's rooms and writes the table of figures
# (issue 24) to stdout and to OUT/rooms.md: per room the target, the outcome, when it was confirmed, the centre
# error against the truth (after the trajectory's Sim(3)), collisions, path, frames, wall time, and the model against
# the target's whole surface above 10 mm. Usage: scripts/rooms_table.sh [OUT [ROOM...]] (default out/rooms, all 10).
# Each room runs live in its own network namespace (root), as fast as the pipeline goes (--fast), 9000-frame budget.
set -uo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
OUT="${1:-$ROOT/out/rooms}"; shift || true
ROOMS=("$@")
[ ${#ROOMS[@]} -gt 0 ] || ROOMS=($(cd "$ROOT/drivers/robot_sim/scenes/rooms" && ls room_*.scene | sed 's/\.scene$//'))
BIN="${OBJSCAN_BUILD_DIR:-$ROOT/build}/bin"
mkdir -p "$OUT"
value() { awk -v k="$1" '$1==k {print $2}'; }
json_number() { tr -d '\n' < "$2" | grep -o "\"$1\": *-\?[0-9.e+-]*" | head -1 | sed 's/.*: *//'; }
table="$OUT/rooms.md"
{
  echo "| room | target | outcome | confirmed at frame | centre error mm | collisions | path m | frames | wall s | mesh p90 mm | mesh max mm | completeness (z > 10 mm) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$table"
port=7700
for room in "${ROOMS[@]}"; do
  port=$((port + 1))
  ns="objscan-rooms-$$-$port"
  ip netns add "$ns" && ip -n "$ns" link set lo up && ip -n "$ns" link set lo multicast on &&
    ip -n "$ns" route add 224.0.0.0/4 dev lo || { echo "cannot create a network namespace (root needed)"; exit 2; }
  d="$OUT/$room"; rm -rf "$d"
  start=$(date +%s)
  ip netns exec "$ns" "$ROOT/objscan" run --sim --closed-loop --scene "$room" --out "$d" --fast \
    --lcm-url "udpm://239.255.76.67:$port?ttl=0&recv_buf_size=4194304" > "$OUT/$room.out" 2>&1
  wall=$(( $(date +%s) - start ))
  ip netns delete "$ns"
  shape=$(tr -d '\n' < "$d/ground_truth/sim_outcome.json" 2>/dev/null | grep -o '"shape": *"[a-z]*"' | sed 's/.*"\([a-z]*\)"$/\1/')
  outcome=$(tr -d '\n' < "$d/plan.json" 2>/dev/null | grep -o '"outcome": *"[a-z_]*"' | sed 's/.*"\([a-z_]*\)"$/\1/')
  confirmed=$(json_number confirmed_seq "$d/target.json" 2>/dev/null)
  collisions=$(json_number collisions "$d/ground_truth/sim_outcome.json" 2>/dev/null)
  path=$(awk -v p="$(json_number path_length_mm "$d/ground_truth/sim_outcome.json" 2>/dev/null)" 'BEGIN{printf "%.1f", p/1000}')
  frames=$(json_number frames "$d/ground_truth/sim_outcome.json" 2>/dev/null)
  err="-"; p90="-"; mx="-"; comp="-"
  if grep -Eq '"state": "(confirmed|lost)"' "$d/target.json" 2>/dev/null; then
    err=$("$BIN/objscan_evaluate" target "$d/target.json" "$d/ground_truth/sim_outcome.json" \
          --align "$d/trajectory.txt" "$d/ground_truth/poses_gt.txt" 2>/dev/null | value center_error_mm)
  fi
  if [ -s "$d/model_mesh.ply" ]; then
    e=$("$BIN/objscan_evaluate" surface "$d/model_mesh.ply" "$d/ground_truth/target_surface.ply" \
        --truth-mesh "$d/ground_truth/target_mesh.ply" --align "$d/trajectory.txt" "$d/ground_truth/poses_gt.txt" \
        --min-z 10 2>/dev/null)
    if [ "$(echo "$e" | value model_points)" != 0 ]; then
      p90=$(echo "$e" | value accuracy_p90); mx=$(echo "$e" | value accuracy_max); comp=$(echo "$e" | value completeness)
    fi
  fi
  row="| $room | ${shape:--} | ${outcome:-none} | ${confirmed:--} | ${err:--} | ${collisions:--} | $path | ${frames:--} | $wall | $p90 | $mx | $comp |"
  echo "$row" >> "$table"
  echo "$row"
done
echo "table: $table"
