#!/usr/bin/env bash
# The speed table (docs/benchmarks.md, "Speed per stage"): runs every Google Benchmark binary in
# $OBJSCAN_BUILD_DIR/bench (default ./build/bench; *_benchmark) and prints one table, one row per benchmark run:
# CPU and wall time per iteration in ms, and the benchmark's own counters (init_ms, points, full_searches, ...).
# Usage: scripts/bench.sh [--quick] [--filter REGEX] [--help]
#   --quick         --benchmark_min_time=0.05 (seconds; this Google Benchmark, 1.7, takes a plain number): a rough
#                   table in little time. Benchmarks with a fixed iteration count (/iterations:N) run as always.
#   --filter REGEX  only the benchmarks whose name matches (passed as --benchmark_filter; binaries with no match
#                   are skipped)
# The machine's load is printed with the table: on a shared machine wall and CPU times are upper bounds.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="${OBJSCAN_BUILD_DIR:-$ROOT/build}"

usage() { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; }

QUICK=0 FILTER=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK=1; shift ;;
    --filter)
      [ $# -ge 2 ] || { echo "bench.sh: --filter needs a REGEX (usage: scripts/bench.sh [--quick] [--filter REGEX] [--help])" >&2; exit 2; }
      FILTER="$2"; shift 2 ;;
    --filter=*) FILTER="${1#--filter=}"; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "bench.sh: unknown argument '$1' (usage: scripts/bench.sh [--quick] [--filter REGEX] [--help])" >&2; exit 2 ;;
  esac
done

BENCH_DIR="$BUILD_DIR/bench"
if [ ! -d "$BENCH_DIR" ]; then
  echo "bench.sh: no benchmark folder $BENCH_DIR; build first: ./objscan build (or set OBJSCAN_BUILD_DIR)" >&2
  exit 1
fi
BINARIES=()
for b in "$BENCH_DIR"/*_benchmark; do
  [ -f "$b" ] && [ -x "$b" ] && BINARIES+=("$b")
done
if [ ${#BINARIES[@]} -eq 0 ]; then
  echo "bench.sh: no *_benchmark binaries in $BENCH_DIR; build first: ./objscan build (or set OBJSCAN_BUILD_DIR)" >&2
  exit 1
fi
command -v python3 > /dev/null || { echo "bench.sh: python3 is needed to read the benchmarks' JSON output" >&2; exit 1; }

# The benchmarks that read the real image sets find them through the source folder (common/test_data.h).
export OBJSCAN_SOURCE_DIR="${OBJSCAN_SOURCE_DIR:-$ROOT}"

ARGS=(--benchmark_format=json)
[ "$QUICK" = 1 ] && ARGS+=(--benchmark_min_time=0.05)
[ -n "$FILTER" ] && ARGS+=("--benchmark_filter=$FILTER")

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
FAILED=0
for b in "${BINARIES[@]}"; do
  name="$(basename "$b")"
  echo "running $name ..." >&2
  if ! "$b" "${ARGS[@]}" > "$WORK/$name.json" 2> "$WORK/$name.err"; then
    echo "bench.sh: $name failed:" >&2
    tail -5 "$WORK/$name.err" >&2
    FAILED=1
  fi
done

python3 - "$WORK" "${BINARIES[@]}" <<'EOF'
import json, os, sys

work, binaries = sys.argv[1], [os.path.basename(b) for b in sys.argv[2:]]
to_ms = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}
standard = {"name", "family_index", "per_family_instance_index", "run_name", "run_type", "repetitions",
            "repetition_index", "threads", "iterations", "real_time", "cpu_time", "time_unit", "error_occurred",
            "error_message", "aggregate_name", "aggregate_unit", "label", "big_o", "rms", "complexity_n"}

def number(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)

rows, context = [], None
for binary in binaries:
    path = os.path.join(work, binary + ".json")
    text = open(path).read().strip() if os.path.exists(path) else ""
    if not text:
        continue  # failed (said above) or no benchmark matched the filter
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        rows.append((binary, "unreadable JSON output", "", "", ""))
        continue
    context = context or doc.get("context")
    for r in doc.get("benchmarks", []):
        name = r["name"]
        if r.get("error_occurred"):
            rows.append((binary, name, "error", "", r.get("error_message", "")))
            continue
        scale = to_ms.get(r.get("time_unit", "ns"), 1e-6)
        counters = [f"{k}={number(v)}" for k, v in r.items() if k not in standard and isinstance(v, (int, float))]
        if r.get("label"):
            counters.insert(0, r["label"])
        rows.append((binary, name, f"{r['cpu_time'] * scale:.3f}", f"{r['real_time'] * scale:.3f}",
                     f"iterations={r.get('iterations', '')}" + ("; " + ", ".join(counters) if counters else "")))

if context:
    load = " ".join(f"{x:.2f}" for x in context.get("load_avg", []))
    print(f"host {context.get('host_name', '?')}, {context.get('num_cpus', '?')} CPUs, load {load or '?'}, "
          f"{context.get('date', '')}")
header = ("binary", "benchmark", "CPU ms/iter", "wall ms/iter", "counters")
widths = [max(len(str(row[i])) for row in rows + [header]) for i in range(len(header))]
def line(row):
    return "| " + " | ".join(str(c).ljust(w) if i != 2 and i != 3 else str(c).rjust(w)
                              for i, (c, w) in enumerate(zip(row, widths))) + " |"
print(line(header))
print("|" + "|".join("-" * (w + 2) if i not in (2, 3) else "-" * (w + 1) + ":" for i, w in enumerate(widths)) + "|")
for row in rows:
    print(line(row))
if not rows:
    print("(no benchmark matched)")
EOF
exit "$FAILED"
