#!/usr/bin/env bash
# The code-weight table (docs/benchmarks.md, "Code weight (issue 27)"): command-line options per program (from each
# program's --help in $OBJSCAN_BUILD_DIR/bin, default ./build/bin; tests excluded), lines of C++ (library and
# program code, tests), and the longest functions. Function lengths come from a brace-matching scan of the .cpp
# files (a definition starts at a line that opens at column 0 with a name and "(", and runs to its matching brace):
# close to what an editor shows, not a parser.
# Usage: scripts/code_weight.sh [--top N] [--help]   (N longest functions, default 10)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="${OBJSCAN_BUILD_DIR:-$ROOT/build}"
TOP=10
while [ $# -gt 0 ]; do
  case "$1" in
    --top)
      [ $# -ge 2 ] || { echo "code_weight.sh: --top needs a number" >&2; exit 2; }
      TOP="$2"; shift 2 ;;
    -h|--help) sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "code_weight.sh: unknown argument '$1' (usage: scripts/code_weight.sh [--top N] [--help])" >&2; exit 2 ;;
  esac
done
case "$TOP" in ''|*[!0-9]*) echo "code_weight.sh: --top must be a whole number, got '$TOP'" >&2; exit 2 ;; esac
[ -d "$BUILD_DIR/bin" ] || { echo "code_weight.sh: no $BUILD_DIR/bin: build first (./objscan build)" >&2; exit 1; }
command -v python3 > /dev/null || { echo "code_weight.sh: python3 is needed for the function lengths" >&2; exit 1; }

total=0
echo "options per program (--help lines that start with --name):"
for b in "$BUILD_DIR"/bin/*; do
  name="$(basename "$b")"
  case "$name" in *_test) continue ;; esac
  [ -x "$b" ] || continue
  n="$("$b" --help 2>&1 | grep -cE '^\s+--[a-z]' || true)"
  printf '  %-26s %4d\n' "$name" "$n"
  total=$((total + n))
done
echo "options in total: $total"

cd "$ROOT"
python3 - "$TOP" <<'EOF'
import glob, re, sys
top = int(sys.argv[1])
dirs = ["common", "drivers", "processes", "viewer", "procman", "tools", "tests"]
files = [f for d in dirs for f in glob.glob(d + "/**/*", recursive=True) if f.endswith((".cpp", ".h"))]
code = [f for f in files if not f.endswith("_test.cpp")]
tests = [f for f in files if f.endswith("_test.cpp")]
count = lambda fs: sum(len(open(f, errors="replace").read().splitlines()) for f in fs)
print(f"C++ lines: {count(code)} in {len(code)} files (library and program code), {count(tests)} in {len(tests)} test files")
start = re.compile(r"^[A-Za-z].*?([A-Za-z_][A-Za-z_0-9:~]*)\(")
found = []
for f in code:
    if not f.endswith(".cpp"):
        continue
    lines = open(f, errors="replace").read().split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        m = start.match(line)
        if m and not line.rstrip().endswith(";") and not line.startswith(("namespace", "struct", "class", "using", "#")):
            j = i
            while j < len(lines) and "{" not in lines[j] and not lines[j].rstrip().endswith(";"):
                j += 1
            if j < len(lines) and "{" in lines[j]:
                depth, k = 0, j
                while k < len(lines):
                    depth += lines[k].count("{") - lines[k].count("}")
                    if depth <= 0:
                        break
                    k += 1
                found.append((k - i + 1, f, i + 1, m.group(1)))
                i = k + 1
                continue
        i += 1
found.sort(reverse=True)
print(f"functions over 150 lines: {sum(1 for n, *_ in found if n > 150)}; the {top} longest:")
for n, f, line, name in found[:top]:
    print(f"  {n:4d}  {name}  ({f}:{line})")
EOF
