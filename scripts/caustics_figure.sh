#!/usr/bin/env bash
# The photon-mapping comparison on scenes/caustics.ron: path, sppm, photon and vcm at equal time
# (5 s each, 4 runs each, 320x240), measured over the whole image and inside the glass ball's caustic
# (the --region). Path tracing this scene to convergence is out of reach (even 4096 spp is
# full of fireflies from the tiny light seen through the glass), so the reference is `sppm` at
# 4096 passes, whose image mean agrees with path's (tests/it/photons.rs); the same comparison
# against the 4096-spp path render is written beside it. About 8 minutes on 2 cores.
# Writes the pages into out/pages/caustics/vs-sppm and out/pages/caustics/vs-path (git ignores
# out/; docs/integrators.md shows the table and the vs-sppm mosaic).
# Usage: scripts/caustics_figure.sh
. "$(dirname "$0")/figure_setup.sh" scenes/caustics.ron out/pages/caustics
REGION=60,115,70,35
[ -f $O/sppm-4096.exr ] || $R render $S -i sppm --spp 4096 --seed 1 -o $O/sppm-4096.exr -q
$R compare $S -i path -i sppm -i photon -i vcm --time 5 --runs 4 --reference $O/sppm-4096.exr --region $REGION \
  -o $O/vs-sppm -q --note "Equal time, 5 s each, 4 runs. Reference: sppm, 4096 passes. Region: the glass ball's caustic, $REGION."
$R compare $S -i path -i sppm -i photon -i vcm --time 5 --runs 4 --reference-spp 4096 --region $REGION \
  -o $O/vs-path -q --note "Equal time, 5 s each, 4 runs. Reference: path, 4096 spp (still full of fireflies). Region: the glass ball's caustic, $REGION."
echo "wrote $O/vs-sppm/index.html and $O/vs-path/index.html"
