#!/usr/bin/env bash
# Images only (issue 25): robot_sim renders the 200-frame orbit with its odometry switched off (--odometry=false,
# images and calibration only, as an image folder or a camera without a robot), objscan_replay runs the whole
# pipeline, and the results are scored against the truth. The pose solver's world starts as the first camera's
# frame; the floor seen among the first landmarks levels it and, with the robot's camera height, makes it metric.
# Bounds are the issue's: online ATE <= 1 mm after Sim(3) with no step more than 20 mm off the true step, final ATE
# <= 0.15 mm, metric scale within 1 % (no alignment scale), mesh p90 <= 0.5 mm and completeness >= 94 % (the same
# model accuracy as with odometry: sphere p90 0.35 / 97.0 %, mesh 0.34 / 99.0 %).
set -euo pipefail
BIN="$1"; SRC="$2"
WORK=$(mktemp -d); trap 'rm -rf "$WORK"' EXIT
FAILED=0
fail() { echo "FAIL: $*"; exit 1; }
source "$SRC/tests/accuracy_lib.sh"

for scene in sphere mesh; do
  d="$WORK/$scene"; mkdir -p "$d"
  render_orbit "$scene" "$d" --odometry=false
  "$BIN/objscan_logtool" count "$d/sim.lcmlog" | grep -q "ROBOT_ODOMETRY" && fail "$scene: odometry in an image-only log"
  "$BIN/objscan_replay" --log "$d/sim.lcmlog" --out "$d/out" > "$d/replay.out" 2>&1 \
    || { tail -30 "$d/replay.out"; fail "replay ($scene)"; }
  GT="$d/gt/poses_gt.txt"
  echo "$scene, images only:"
  "$BIN/objscan_evaluate" trajectory "$d/out/trajectory_online.txt" "$GT" > "$d/online.txt" || fail "evaluate online"
  "$BIN/objscan_evaluate" trajectory "$d/out/trajectory.txt" "$GT" > "$d/final.txt" || fail "evaluate final"
  check "$scene online ATE RMSE (mm)" "$(value ate_rmse "$d/online.txt")" "<=" 1.0
  check "$scene online registered fraction" "$(value registered_fraction "$d/online.txt")" ">=" 0.98
  check "$scene final ATE RMSE (mm)" "$(value ate_rmse "$d/final.txt")" "<=" 0.15
  for f in online final; do
    check "$scene $f scale error (metric, no alignment scale)" \
      "$(awk -v s="$(value scale "$d/$f.txt")" 'BEGIN{d=s-1; if(d<0)d=-d; printf "%.5f", d}')" "<=" 0.01
  done
  # Largest jump: consecutive online positions against the true step (metric: no scale to apply).
  jump=$(awk 'FNR==1{file++} /^#/||NF<8{next} file==1{t[$1]=$2" "$3" "$4; next}
              ($1 in t){split(t[$1],g," "); if(have){de=sqrt(($2-px)^2+($3-py)^2+($4-pz)^2); dg=sqrt((g[1]-gx)^2+(g[2]-gy)^2+(g[3]-gz)^2);
                e=de-dg; if(e<0)e=-e; if(e>m)m=e} px=$2;py=$3;pz=$4;gx=g[1];gy=g[2];gz=g[3];have=1}
              END{printf "%.3f", m}' "$GT" "$d/out/trajectory_online.txt")
  check "$scene largest online step error (mm)" "$jump" "<=" 20
  grep -q '^# scale: metric' "$d/out/trajectory.txt" || fail "$scene: trajectory.txt does not say metric"
  "$BIN/objscan_evaluate" surface "$d/out/model_mesh.ply" "$d/gt/target_surface.ply" --truth-mesh "$d/gt/target_mesh.ply" \
    --align "$d/out/trajectory.txt" "$GT" --visible-from "$GT" > "$d/mesh.txt" || fail "evaluate mesh"
  check "$scene mesh accuracy p90 (mm)" "$(value accuracy_p90 "$d/mesh.txt")" "<=" 0.5
  check "$scene mesh completeness (visible surface, 2 mm)" "$(value completeness "$d/mesh.txt")" ">=" 0.94
  info "$scene mesh accuracy max (mm)" "$(value accuracy_max "$d/mesh.txt")"
done
[ "$FAILED" = 0 ] || fail "accuracy below the bounds above"
echo "PASS: image-only orbits posed, scaled and modeled as with odometry"
