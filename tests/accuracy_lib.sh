# Shared by the accuracy test scripts: read figures from objscan_evaluate output and check them against bounds.
# Source it after setting FAILED=0; check() sets FAILED=1 on a violated bound.

# value KEY FILE: the number after KEY in an objscan_evaluate output.
value() { awk -v k="$1" '$1==k {print $2}' "$2"; }

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
