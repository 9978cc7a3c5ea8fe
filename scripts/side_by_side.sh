#!/bin/bash
# usage: scripts/side_by_side.sh BIN_A BIN_B [ROUNDS]
# Runs `bench realtime --seconds 9` of two graspsim binaries at the same time, one
# pinned to each core, swapping cores each round, and prints the closing and
# lift-off steps' traversal and pre-solve figures of each (rows without rendering,
# 1000-1500 ms into the grasp cycle). Runs minutes apart differ more than most changes.
set -e
cd "$(dirname "$0")/.."
out=${TMPDIR:-/tmp}
for i in $(seq "${3:-2}"); do
  if (( i % 2 )); then ca=0; cb=1; else ca=1; cb=0; fi
  $1 bench realtime --seconds 9 --cpu $ca --steps-csv "$out/sbsA$i.csv" --json > /dev/null 2>&1 &
  $2 bench realtime --seconds 9 --cpu $cb --steps-csv "$out/sbsB$i.csv" --json > /dev/null 2>&1 &
  wait
  python3 scripts/side_by_side_stats.py "$out/sbsA$i.csv" "$out/sbsB$i.csv"
done
