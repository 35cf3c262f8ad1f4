#!/usr/bin/env bash
# The volumetric families at equal time on the two media scenes of scenes/: the foggy room
# lit through a window (single and multiple scattering of sunlight, the camera in the fog)
# and the volumetric caustic (a glass ball focusing a small light into a cone of light in
# fog). Every integrator that renders media renders for the same wall-clock time (TIME
# seconds, default 10) at a reduced size, judged against one reference per scene rendered
# twice with independent seeds: the first is every row's reference, and the relMSE between
# the two, halved, is the reference's own share of every row's relMSE (printed under each
# table). References: `volpath` in the room, `bdpt` for the caustic (volpath finds the cone
# only by chance). About 12 minutes on 2 cores. Writes out/pages/media/SCENE/ (git ignores
# out/); docs/integrators.md shows the tables.
# Usage: scripts/media_table.sh [integrators...]
. "$(dirname "$0")/figure_setup.sh" scenes/fog_room.ron out/pages/media
TIME=${TIME:-10}
INTEGRATORS=${*:-volpath lighttracer bdpt pssmlt mmlt}
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
  "scenes/fog_room.ron 160x120 8 volpath 4096"
  "scenes/volumetric_caustic.ron 160x120 12 bdpt 1024"
)
# References first, then the timed renders (nothing else should run during those).
for s in "${SCENES[@]}"; do reference $s; done
for s in "${SCENES[@]}"; do compare $s; done
