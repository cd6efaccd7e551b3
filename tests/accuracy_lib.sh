# Shared by the accuracy test scripts: render the sim orbit, read figures from objscan_evaluate output and check them
# against bounds. Source it after setting BIN, SRC, FAILED=0 and fail(); check() sets FAILED=1 on a violated bound.

# render_orbit SCENE DIR [robot_sim options...]: robot_sim renders the orbit of the scene drivers/robot_sim/scenes/
# SCENE.scene (FRAMES frames, default 200, seed 1, JPEG 95) into DIR/sim.lcmlog, ground truth into DIR/gt (written
# aside, never fed to the pipeline).
render_orbit() {
  local scene="$1" d="$2"; shift 2
  "$BIN/robot_sim" --lcm-url "file://$d/sim.lcmlog?mode=w" --scene "$SRC/drivers/robot_sim/scenes/$scene.scene" \
    --frames "${FRAMES:-200}" --seed 1 --realtime=false --encoding jpeg --jpeg-quality 95 --ground-truth-dir "$d/gt" \
    "$@" > "$d/sim.out" 2>&1 || { cat "$d/sim.out"; fail "robot_sim ($scene)"; }
}

# value KEY FILE: the number after KEY in an objscan_evaluate output.
value() { awk -v k="$1" '$1==k {print $2}' "$2"; }

# info LABEL TEXT: a figure reported for comparison only (never fails).
info() { printf '  %-52s %10s  (reported only)\n' "$1" "$2"; }

# check LABEL VALUE OP BOUND [target]: OP is <= or >=; "target" only reports (MET / NOT MET), a bound fails the test.
check() {
  local label="$1" v="$2" op="$3" bound="$4" kind="${5:-bound}" ok
  if ! [[ "$v" =~ ^-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?$ ]]; then  # missing or not a number: never passes
    printf '  %-52s %10s  not a number\n' "$label" "'$v'"
    [ "$kind" = "target" ] || FAILED=1
    return 0
  fi
  if [ "$op" = "<=" ]; then ok=$(awk -v a="$v" -v b="$bound" 'BEGIN{print (a<=b)?1:0}')
  else ok=$(awk -v a="$v" -v b="$bound" 'BEGIN{print (a>=b)?1:0}'); fi
  if [ "$kind" = "target" ]; then
    printf '  %-52s %10s  issue target %s %-8s %s\n' "$label" "$v" "$op" "$bound" "$([ "$ok" = 1 ] && echo MET || echo 'NOT MET')"
  else
    printf '  %-52s %10s  %s %-8s %s\n' "$label" "$v" "$op" "$bound" "$([ "$ok" = 1 ] && echo ok || echo FAIL)"
    [ "$ok" = 1 ] || FAILED=1
  fi
}

# trajectory_checks NAME OUTDIR GT: issue 3's pose targets for OUTDIR/trajectory_online.txt (as published) and
# OUTDIR/trajectory.txt (after the final BA) against the true poses GT; figures kept in OUTDIR/NAME-{online,final}.txt.
trajectory_checks() {
  local name="$1" out="$2" gt="$3" f
  for f in online final; do
    local file="$out/trajectory.txt"; [ $f = online ] && file="$out/trajectory_online.txt"
    "$BIN/objscan_evaluate" trajectory "$file" "$gt" > "$out/$name-$f.txt" || fail "evaluate $name $f"
    local limit=0.3; [ $f = online ] && limit=2.0
    check "$name $f ATE RMSE (mm)" "$(value ate_rmse "$out/$name-$f.txt")" "<=" $limit
    local scale; scale=$(value scale "$out/$name-$f.txt")
    check "$name $f scale error" "$(awk -v s="$scale" 'BEGIN{d=s-1; if(d<0)d=-d; printf "%.5f", d}')" "<=" 0.01
    check "$name $f registered fraction" "$(value registered_fraction "$out/$name-$f.txt")" ">=" 0.98
  done
  check "$name online rotation mean (deg)" "$(value rotation_mean_deg "$out/$name-online.txt")" "<=" 0.2
}
