#!/usr/bin/env bash
# Sets up, builds and runs the default scene (the paper's box grasp) with its
# output files, video and figures in out/demo/, then replays the shipped tracker
# session (assets/demo_session.lcmlog) headless.
# Extra arguments go to `graspsim run`, e.g. scripts/demo.sh --duration 1
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
mkdir -p build
echo "demo: building graspsim (log: build/demo-build.log) ..."
if ! scripts/build.sh release --target graspsim >build/demo-build.log 2>&1; then
  tail -n 40 build/demo-build.log
  echo "demo: the build failed; the whole log is build/demo-build.log" >&2
  exit 1
fi
bin=build/release/graspsim
out=out/demo
video=()
if command -v ffmpeg >/dev/null; then video=(--video "$out/grasp.mp4"); fi
echo "demo: $bin run config/paper_box_grasp.yaml --out $out ${video[*]} $*"
"$bin" run config/paper_box_grasp.yaml --out "$out" "${video[@]}" "$@"
echo
"$bin" plot "$out" || echo "demo: no figures (gnuplot missing: scripts/setup.sh installs it)"
echo
echo "demo: $bin replay assets/demo_session.lcmlog"
"$bin" replay assets/demo_session.lcmlog
echo
echo "demo: the grasp's files are in $out/ (trajectory.csv, contacts.csv, timings.csv, summary.json${video:+, grasp.mp4}, plots/)"
echo "demo: the binary is $bin; every command has --help"
