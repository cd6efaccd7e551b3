#!/usr/bin/env bash
# The run report (issue 29): `objscan run` writes DIR/report.html at its end; a headless browser (chromium) opens it
# with no network and finds the status, the four plots and the model's five pictures, inlined; the pictures are
# renders of the model (not blank). `objscan report` on a folder that is no run fails with a message.
# Exit 77 (skipped) without namespaces or chromium.
set -euo pipefail
BIN="$1"; SRC="$2"
command -v chromium > /dev/null || { echo "SKIP: chromium not installed (scripts/setup_deps.sh installs it)"; exit 77; }
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name report); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"

in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene box --frames 60 --out "$WORK/run" \
  --lcm-url "udpm://239.255.76.67:7683?ttl=0&recv_buf_size=4194304" > "$WORK/run.out" 2>&1 \
  || { tail -n 30 "$WORK/run.out"; fail "objscan run failed"; }
REPORT="$WORK/run/report.html"
[ -s "$REPORT" ] || { tail -n 20 "$WORK/run.out"; fail "the run wrote no report.html"; }
grep -q "report.html (" "$WORK/run.out" || fail "the run did not say where the report is"

# Self-contained: nothing to fetch (the only URL is SVG's namespace name, which is never fetched).
if grep -oE '(src|href)="[a-z]+:' "$REPORT" | grep -v 'src="data:' | grep -q .; then
  fail "report.html refers to something outside itself"
fi

# The browser, inside the namespace (no network), with a fresh profile.
browse() { ip netns exec "$NS" chromium --headless=new --no-sandbox --disable-gpu --user-data-dir="$WORK/profile" \
             --window-size=1280,4000 "$@" "file://$REPORT" 2> "$WORK/chromium.err"; }
browse --dump-dom > "$WORK/dom.html" || { cat "$WORK/chromium.err"; fail "chromium could not open the report"; }
grep -q 'id="status">ok<' "$WORK/dom.html" || fail "the browser's page lacks the status"
svgs=$(grep -o '<svg' "$WORK/dom.html" | wc -l)
pictures=$(grep -o 'src="data:image/png;base64,' "$WORK/dom.html" | wc -l)
echo "report: $(du -k "$REPORT" | cut -f1) kB, $svgs plots, $pictures pictures"
[ "$svgs" -eq 4 ] || fail "expected 4 plots in the page, found $svgs"
grep -q "no data" "$WORK/dom.html" && fail "a plot has no data"
if command -v xvfb-run > /dev/null; then
  [ "$pictures" -eq 5 ] || fail "expected the model from 5 sides, found $pictures pictures"
  # Each picture is a PNG of a render: decoded, it is large and not one colour.
  i=0
  for b64 in $(grep -o 'data:image/png;base64,[A-Za-z0-9+/=]*' "$REPORT" | sed 's/^data:image\/png;base64,//'); do
    i=$((i + 1))
    echo "$b64" | base64 -d > "$WORK/p$i.png"
    [ "$(head -c 8 "$WORK/p$i.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] || fail "picture $i is no PNG"
    [ "$(stat -c %s "$WORK/p$i.png")" -gt 50000 ] || fail "picture $i is nearly empty ($(stat -c %s "$WORK/p$i.png") bytes)"
  done
fi
browse --screenshot="$WORK/page.png" > /dev/null || { cat "$WORK/chromium.err"; fail "chromium could not render the report"; }
[ "$(stat -c %s "$WORK/page.png")" -gt 100000 ] || fail "the rendered page is nearly blank"

# Not a run folder: a clear error and a non-zero exit.
mkdir -p "$WORK/empty"
rc=0; "$SRC/objscan" report "$WORK/empty" > "$WORK/empty.out" 2>&1 || rc=$?
[ "$rc" != 0 ] && grep -q "is it a run folder" "$WORK/empty.out" || { cat "$WORK/empty.out"; fail "objscan report on an empty folder: rc $rc"; }
echo "PASS: report.html written by the run, self-contained, opened by a headless browser with status, plots and pictures"
