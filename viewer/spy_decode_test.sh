#!/usr/bin/env bash
# ctest "spy": every objscan type written to a log decodes with objscan_lcmtypes.jar through lcm.jar's log API,
# and a log with an undecodable event is refused. Exit 77 (skipped) without java.
# Usage: spy_decode_test.sh WRITER CLASSES_DIR TYPES_JAR LCM_JAR
set -u
writer=$1 classes=$2 types_jar=$3 lcm_jar=$4
command -v java > /dev/null 2>&1 || { echo "java not installed: skipped"; exit 77; }
for f in "$writer" "$classes/LogDecodeCheck.class" "$types_jar" "$lcm_jar"; do
  [ -e "$f" ] || { echo "FAIL: missing $f"; exit 1; }
done
tmp=$(mktemp -d "${TMPDIR:-/tmp}/objscan_spy_decode.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
cp="$lcm_jar:$types_jar:$classes"

"$writer" "$tmp/all.lcmlog" || { echo "FAIL: writer"; exit 1; }
if ! java -cp "$cp" LogDecodeCheck "$tmp/all.lcmlog" "$types_jar" --require-all; then
  echo "FAIL: the log with every objscan type did not decode completely"
  exit 1
fi
"$writer" "$tmp/garbage.lcmlog" --with-garbage || { echo "FAIL: writer"; exit 1; }
if java -cp "$cp" LogDecodeCheck "$tmp/garbage.lcmlog" "$types_jar" --require-all 2> "$tmp/err"; then
  echo "FAIL: an undecodable event was accepted"
  exit 1
fi
grep -q "unknown fingerprint" "$tmp/err" || { echo "FAIL: wrong failure:"; cat "$tmp/err"; exit 1; }
echo "PASS"
