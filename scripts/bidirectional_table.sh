#!/usr/bin/env bash
# The bidirectional family at equal time on three scenes where the families differ: the
# Cornell box (all diffuse), the caustics scene (a glass ball and a mirror under a small
# light) and light through a door ajar (scenes/door.ron). Every integrator renders for the
# same wall-clock time (TIME seconds, default 10) at a reduced size, and is judged against one
# reference per scene, rendered twice with independent seeds: the first is the reference of
# every row, and the relMSE between the two, halved, is the reference's own share of every
# row's relMSE (the noise floor printed under each table). References: `path` on the Cornell
# box, `vcm` on the caustics (path cannot converge them), `bdpt` through the door. About 11
# minutes on 2 cores. Writes out/pages/bidirectional/SCENE/ (git ignores out/);
# docs/integrators.md shows the tables.
# Usage: scripts/bidirectional_table.sh [integrators...]
. "$(dirname "$0")/figure_setup.sh" scenes/cornell_box.ron out/pages/bidirectional
TIME=${TIME:-10}
INTEGRATORS=${*:-path lighttracer bdpt bpm vcm sppm sppm-pixel}
reference() { # scene size max-depth reference-integrator reference-spp
  local out
  out=$O/$(basename "$1" .ron)
  mkdir -p "$out"
  for seed in 1000 2000; do
    [ -f "$out/reference-$seed.exr" ] || $R render "$1" --size "$2" -i "$4" \
      --spp "$5" --seed "$seed" -p max-depth="$3" -o "$out/reference-$seed.exr" -q
  done
}
compare() { # scene size max-depth reference-integrator reference-spp
  local name out
  name=$(basename "$1" .ron)
  out=$O/$name
  local args=()
  for i in $INTEGRATORS; do args+=(-i "$i" -p "$i.max-depth=$3"); done
  $R compare "$1" --size "$2" "${args[@]}" --time "$TIME" \
    --reference "$out/reference-1000.exr" -o "$out/equal-time" -q \
    --note "Equal time, $TIME s each, max-depth $3, $2. Reference: $4, $5 spp, seed 1000."
  echo "== $name: reference noise (the seed-2000 reference against the seed-1000 one; half its relMSE is in every row)"
  $R diff "$out/reference-2000.exr" "$out/reference-1000.exr" | grep -E "relMSE|FLIP|mean"
  echo "wrote $out/equal-time/index.html"
}
SCENES=(
  "scenes/cornell_box.ron 128x128 7 path 4096"
  "scenes/caustics.ron 160x120 10 vcm 2048"
  "scenes/door.ron 160x120 10 bdpt 2048"
)
# References first, then the timed renders (nothing else should run during those).
for s in "${SCENES[@]}"; do reference $s; done
for s in "${SCENES[@]}"; do compare $s; done
