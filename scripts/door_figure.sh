#!/usr/bin/env bash
# Light through a door (scenes/door.ron): path, lighttracer, bdpt and sppm at equal time (10 s
# each, 320x240, max-depth 10). Camera paths rarely find the lamp through the door's gap;
# light paths cannot miss it. The reference is bdpt at 2048 spp (path at that count is still
# speckled), about 12 minutes on 2 cores. Writes out/pages/door/ (git ignores out/;
# docs/integrators.md shows the table).
# Usage: scripts/door_figure.sh
. "$(dirname "$0")/figure_setup.sh" scenes/door.ron out/pages/door
# The reference takes its own seed, so that its noise is independent of the renders'.
[ -f $O/bdpt-2048.exr ] || $R render $S -i bdpt --spp 2048 --seed 1000 -p max-depth=10 -o $O/bdpt-2048.exr -q
$R compare $S -i path -i lighttracer -i bdpt -i sppm --time 10 \
  -p path.max-depth=10 -p lighttracer.max-depth=10 -p bdpt.max-depth=10 -p sppm.max-depth=10 \
  --reference $O/bdpt-2048.exr -o $O/equal-time -q \
  --note "Equal time, 10 s each, max-depth 10. Reference: bdpt, 2048 spp."
echo "wrote $O/equal-time/index.html"
