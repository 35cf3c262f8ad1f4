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
INTEGRATORS=${*:-volpath lighttracer bdpt vcm bpm photon sppm sppm-pixel pssmlt mmlt}
. "$(dirname "$0")/equal_time.sh"
SCENES=(
  "scenes/fog_room.ron 160x120 8 volpath 4096"
  "scenes/volumetric_caustic.ron 160x120 12 bdpt 4096"
)
# References first, then the timed renders (nothing else should run during those).
for s in "${SCENES[@]}"; do reference $s; done
for s in "${SCENES[@]}"; do compare $s; done
