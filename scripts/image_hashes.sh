#!/usr/bin/env bash
# Prints a SHA-256 of the linear EXR that every integrator renders of every scene in scenes/
# and of the Mitsuba and pbrt scenes in scenes/mitsuba and scenes/pbrt (small images, a few
# samples per pixel, fixed seed), one line per render, then the hash of the image of each
# scene as `raylab import` writes it (its text may change; what it describes may not). Run it with the
# binary before and after a change that must not move any image, and diff the two listings:
#   scripts/image_hashes.sh target/release/raylab > before.txt
# Usage: image_hashes.sh [BINARY] [SIZE] [SPP]
set -euo pipefail
bin=${1:-target/release/raylab}
size=${2:-40x30}
spp=${3:-4}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
integrators=$("$bin" integrators --names 2>/dev/null || "$bin" integrators | awk '/^[a-z][a-z-]*$/')
for scene in scenes/*.ron scenes/mitsuba/*.xml scenes/pbrt/*.pbrt; do
  for i in $integrators; do
    params=()
    # The report's tracer grows like branching^depth: keep it small.
    [ "$i" = fixed-depth ] && params=(-p depth=2 -p branching=4)
    "$bin" render "$scene" -i "$i" "${params[@]}" --size "$size" --spp "$spp" --seed 7 -q \
      -o "$out/img.exr" >/dev/null 2>&1 || { echo "$(basename "$scene") $i FAILED"; continue; }
    echo "$(basename "$scene") $i $(sha256sum "$out/img.exr" | cut -c1-16)"
  done
done
for scene in scenes/mitsuba/*.xml scenes/pbrt/*.pbrt; do
  # import writes beside the scene: a copy of the folder keeps scenes/ as it is.
  rm -rf "$out/copy" && cp -r "$(dirname "$scene")" "$out/copy"
  "$bin" import "$out/copy/$(basename "$scene")" -o "$out/copy/imported.ron" >/dev/null 2>&1 \
    || { echo "$(basename "$scene") import FAILED"; continue; }
  "$bin" render "$out/copy/imported.ron" --size "$size" --spp "$spp" --seed 7 -q -o "$out/img.exr" \
    >/dev/null 2>&1 || { echo "$(basename "$scene") import render FAILED"; continue; }
  echo "$(basename "$scene") import $(sha256sum "$out/img.exr" | cut -c1-16)"
done
