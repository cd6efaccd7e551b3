#!/usr/bin/env bash
# peer_table.sh — objscan and COLMAP side by side on the same image sets, in one run (issue 25): views posed, camera
# centre error after Sim(3) alignment to the set's truth, rotation error, wall time.
#
# Usage: scripts/peer_table.sh OUT [--sim-frames N] [SET...]
#   SET: temple, dino (Middlebury sparse rings from $OBJSCAN_DATA_DIR, default ../shared/data) and sim (the
#   simulator's sphere orbit without odometry, first N frames, default 60); default: all three.
# Each set: `objscan run --dataset` with no flags (images + calibration only; the Middlebury folders as they come),
# its session log exported to a dataset folder (images, calib.yaml, poses_gt.txt: objscan_export), then
# scripts/colmap_peer.sh on that folder (COLMAP 3.8 CPU sparse, the known intrinsics fixed; installs the Debian
# package when missing) scoring both trajectories with objscan_evaluate. Writes OUT/peers.md and prints it.
# The Oxford dinosaur is not in the table: its projection matrices are no metric calibration (objscan's
# dinosaur_test runs the method on its given tracks instead).
# Wall time: objscan = the session's wall_time_s (summary.json: processes up to the written model, the final
# phase included); COLMAP = feature extraction + matching + mapping. Both on this machine's 2 cores.
# Exit status: 0 with the table written, 1 when a step failed (message on stderr), 2 on a bad command line.
set -uo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD="${OBJSCAN_BUILD_DIR:-$ROOT/build}"
BIN="$BUILD/bin"
DATA="${OBJSCAN_DATA_DIR:-$ROOT/../shared/data}"
die() { echo "peer_table: error: $*" >&2; exit 1; }
usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; }

[ $# -ge 1 ] || { usage >&2; exit 2; }
OUT="$1"; shift
SIM_FRAMES=60
SETS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --sim-frames) SIM_FRAMES="$2"; shift 2 ;;
    temple|dino|sim) SETS+=("$1"); shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "peer_table: unknown argument $1" >&2; usage >&2; exit 2 ;;
  esac
done
[ ${#SETS[@]} -gt 0 ] || SETS=(temple dino sim)
[[ "$SIM_FRAMES" =~ ^[0-9]+$ ]] && [ "$SIM_FRAMES" -ge 10 ] || die "--sim-frames must be a whole number >= 10"
for tool in objscan_export objscan_evaluate robot_sim; do [ -x "$BIN/$tool" ] || die "$BIN/$tool missing: ./objscan build"; done
mkdir -p "$OUT" || die "cannot create $OUT"
OUT="$(cd "$OUT" && pwd)"

rows=()
# run_set NAME DATASET_SOURCE: objscan on the source (a Middlebury folder or an image folder), then COLMAP.
run_set() {
  local name="$1" source="$2" d="$OUT/$1"
  rm -rf "$d"; mkdir -p "$d"
  "$ROOT/objscan" run --dataset "$source" --out "$d/objscan" > "$d/objscan.out" 2>&1
  local rc=$?
  [ -s "$d/objscan/session.lcmlog" ] || { tail -n 20 "$d/objscan.out" >&2; die "$name: objscan run wrote no session log"; }
  "$BIN/objscan_export" --log "$d/objscan/session.lcmlog" --out "$d/dataset" > "$d/export.out" 2>&1 ||
    { tail -n 5 "$d/export.out" >&2; die "$name: objscan_export"; }
  [ -s "$d/dataset/poses_gt.txt" ] || die "$name: the set has no ground truth to score against"
  local wall status
  wall=$(grep -o '"wall_time_s": *[0-9.]*' "$d/objscan/summary.json" | head -1 | sed 's/.*: *//')
  status=$(grep -o '"status": *"[a-z]*"' "$d/objscan/summary.json" | head -1 | sed 's/.*"\([a-z]*\)"$/\1/')
  local traj_args=()
  [ -s "$d/objscan/trajectory.txt" ] && traj_args=(--objscan-trajectory "$d/objscan/trajectory.txt" --objscan-time "${wall:-0}")
  local colmap_failed=""
  if ! "$ROOT/scripts/colmap_peer.sh" "$d/dataset" "$d/colmap" --build "$BUILD" "${traj_args[@]}" "${COLMAP_ARGS[@]}" \
      > "$d/colmap.out" 2>&1; then
    # COLMAP made no model (e.g. "no good initial image pair"): its row says so; objscan is scored on its own.
    colmap_failed=$(grep -h -m1 -E "No good initial image pair|ERROR|error:" "$d/colmap/logs/mapper.log" "$d/colmap.out" \
                    2>/dev/null | head -1 | sed 's/^[ =>]*//' | cut -c1-120)
    [ -n "$colmap_failed" ] || colmap_failed="colmap_peer.sh failed (see $d/colmap.out)"
    mkdir -p "$d/colmap"
    echo "method     registered  ate_rmse_mm rot_mean_deg          scale     wall_s" > "$d/colmap/results.txt"
    if [ ${#traj_args[@]} -gt 0 ]; then
      local e frames
      e=$("$BIN/objscan_evaluate" trajectory "$d/objscan/trajectory.txt" "$d/dataset/poses_gt.txt") ||
        die "$name: objscan_evaluate"
      frames=$(grep -vc '^#' "$d/dataset/poses_gt.txt")
      awk -v w="${wall:-0}" -v f="$frames" 'BEGIN {m = 0; a = "-"; r = "-"; s = "-"}
        $1=="matched" {m=$2} $1=="ate_rmse" {a=$2} $1=="rotation_mean_deg" {r=$2}
        $1=="scale" {s=$2} END {printf "objscan %d/%d %s %s %s %.1f\n", m, f, a, r, s, w}' <<< "$e" \
        >> "$d/colmap/results.txt"
    fi
  fi
  # The ring radius (mean distance of the true centres from their centroid) to state errors as % of it.
  local radius
  radius=$(awk 'BEGIN {n = 0} !/^#/ && NF >= 8 {x[n]=$2; y[n]=$3; z[n]=$4; n++}
                END {for (i=0;i<n;i++) {cx+=x[i]; cy+=y[i]; cz+=z[i]}; cx/=n; cy/=n; cz/=n;
                     for (i=0;i<n;i++) r+=sqrt((x[i]-cx)^2+(y[i]-cy)^2+(z[i]-cz)^2); if (n > 0) printf "%.1f", r/n}' \
           "$d/dataset/poses_gt.txt")
  while read -r method registered ate rot scale wall_s; do
    [ "$method" = method ] && continue
    local pct="-"
    [[ "$ate" =~ ^[0-9.]+$ && "$radius" =~ ^[0-9.]+$ ]] && pct=$(awk -v a="$ate" -v r="$radius" 'BEGIN {printf "%.2f", 100 * a / r}')
    local note=""
    [ "$method" = objscan ] && note="run status $status (exit $rc)"
    rows+=("| $name | $method | $registered | $ate ($pct %) | $rot | $wall_s | $note |")
  done < "$d/colmap/results.txt"
  [ -n "$colmap_failed" ] && rows+=("| $name | colmap | 0 | - | - | - | no model: $colmap_failed |")
  if [ ! -s "$d/objscan/trajectory.txt" ]; then
    rows+=("| $name | objscan | 0 | - | - | ${wall:-?} | no trajectory: run status $status (exit $rc) |")
  fi
  echo "peer_table: $name done (radius $radius mm)" >&2
}

for set in "${SETS[@]}"; do
  case "$set" in
    temple) COLMAP_ARGS=(); run_set temple "$DATA/middlebury_templeSparseRing" ;;
    dino) COLMAP_ARGS=(); run_set dino "$DATA/middlebury_dinoSparseRing" ;;
    sim)
      sd="$OUT/sim_source"; rm -rf "$sd"; mkdir -p "$sd"
      "$BIN/robot_sim" --lcm-url "file://$sd/sim.lcmlog?mode=w" --scene "$ROOT/drivers/robot_sim/scenes/sphere.scene" \
        --frames "$SIM_FRAMES" --realtime=false --encoding jpeg --jpeg-quality 95 --odometry=false \
        --ground-truth-dir "$sd/gt" > "$sd/sim.out" 2>&1 || die "sim: robot_sim"
      "$BIN/objscan_export" --log "$sd/sim.lcmlog" --out "$sd/folder" > "$sd/export.out" 2>&1 || die "sim: objscan_export"
      rm -f "$sd/folder/odometry.txt"  # images only
      COLMAP_ARGS=(--matcher sequential)
      run_set sim "$sd/folder" ;;
  esac
done

{
  echo "| set | method | views posed | camera centre error RMSE mm (% of the ring radius) | rotation error mean deg | wall s | note |"
  echo "|---|---|---|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} > "$OUT/peers.md"
cat "$OUT/peers.md"
