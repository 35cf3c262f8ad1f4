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
. "$(dirname "$0")/equal_time.sh"
SCENES=(
  "scenes/cornell_box.ron 128x128 7 path 4096"
  "scenes/caustics.ron 160x120 10 vcm 2048"
  "scenes/door.ron 160x120 10 bdpt 2048"
)
# References first, then the timed renders (nothing else should run during those).
for s in "${SCENES[@]}"; do reference $s; done
for s in "${SCENES[@]}"; do compare $s; done
