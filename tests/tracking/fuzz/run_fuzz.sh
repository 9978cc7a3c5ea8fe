#!/usr/bin/env bash
# Builds the DTrack parser's libFuzzer target with Debian's clang (the main
# build uses g++) and runs it for a bounded time, seeded with the example
# packets of tests/data/dtrack/. Any crash, sanitizer report or broken
# invariant fails (non-zero exit) and leaves the input in OUT_DIR.
# Usage: run_fuzz.sh OUT_DIR [SECONDS]
set -euo pipefail
src="$(cd "$(dirname "$0")/../../.." && pwd)"
out="${1:?usage: run_fuzz.sh OUT_DIR [SECONDS]}"
seconds="${2:-20}"
cxx="${CLANGXX:-clang++}"
if ! command -v "$cxx" >/dev/null; then
  echo "run_fuzz.sh: $cxx not found (apt-get install clang libclang-rt-14-dev)" >&2
  exit 1
fi
mkdir -p "$out/corpus"
bin="$out/dtrack_fuzz"
deps=("$src/tracking/dtrack_parser.cpp" "$src/tracking/dtrack_parser.h" "$src/tests/tracking/fuzz/dtrack_fuzz.cpp")
rebuild=0
[ -x "$bin" ] || rebuild=1
for d in "${deps[@]}"; do [ "$d" -nt "$bin" ] && rebuild=1; done
if [ $rebuild = 1 ]; then
  "$cxx" -std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
    -I"$src" -isystem /usr/include/eigen3 \
    "$src/tracking/dtrack_parser.cpp" "$src/tests/tracking/fuzz/dtrack_fuzz.cpp" -o "$bin"
fi
cp "$src"/tests/data/dtrack/*.txt "$out/corpus/"
cd "$out"
exec "$bin" -dict="$src/tests/tracking/fuzz/dtrack.dict" -max_total_time="$seconds" -max_len=4096 -timeout=5 -print_final_stats=1 corpus
