#!/usr/bin/env bash
# raylab against Intel Embree 3 on the bench cases: installs Debian's libembree-dev if missing,
# builds raylab in release with the `embree` feature, and runs `raylab bench --embree` at 1 and
# 2 threads (1 M rays per measurement, the 1.31 M-triangle icosphere), three rounds of raylab
# and Embree in turn, of which it prints the medians and the range of the ratios.
# Usage: scripts/embree_comparison.sh [output file]   (the report is also printed)
# Extra cargo/bench knobs: CARGO_JOBS (default: cargo's), THREADS (default: 1,2), ROUNDS
# (default: 3).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-}

if ! [ -e /usr/include/embree3/rtcore.h ]; then
  echo "installing: libembree-dev"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libembree-dev >/dev/null
fi

jobs=()
[ -n "${CARGO_JOBS:-}" ] && jobs=(-j "$CARGO_JOBS")
cargo build --release --features embree "${jobs[@]}"

cmd=(target/release/raylab bench --embree --threads "${THREADS:-1,2}" --rounds "${ROUNDS:-3}")
if [ -n "$out" ]; then
  mkdir -p "$(dirname "$out")"
  "${cmd[@]}" | tee "$out"
else
  "${cmd[@]}"
fi
