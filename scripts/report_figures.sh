#!/usr/bin/env bash
# Reproduces the report's figures on scenes/report_room.ron with `raylab compare`, one page per
# comparison in out/pages/report/ (equal-time, shadow-grid, depth, branching; git ignores
# out/). docs/report.md shows their tables, mosaics and sweep plots.
# Takes about 9 minutes on 2 cores. Usage: scripts/report_figures.sh
. "$(dirname "$0")/figure_setup.sh" scenes/report_room.ron out/pages/report

# The four integrators at equal time (4 s each), 400x400, four independent runs each (means
# with 95% intervals, variance and squared bias, convergence curves), against a 1024-spp path
# reference whose own variance is subtracted from every error.
$R compare $S -i whitted -i fixed-depth -i russian-roulette -i path --time 4 --runs 4 -o $O/equal-time -q

# Figures 13-16: shadow rays 3x3, 5x5, 7x7, 20x20 (report defaults otherwise: depth 2,
# branching 20, 4 spp). Half the report's resolution to keep it to a minute.
$R compare $S -i fixed-depth --sweep shadow-grid=3,5,7,20 --spp 4 --size 200x200 -o $O/shadow-grid -q \
  --note "Report figures 13-16 at 200x200 (half the report's 400x400 per side), 4 spp, depth 2, branching 20."

# Figures 17-20: 1 to 4 bounces. The report's 4 bounces took 24 hours at 400x400; here 64x64
# at 1 spp, so the sweep runs in a couple of minutes.
$R compare $S -i fixed-depth --sweep depth=1,2,3,4 --spp 1 --size 64x64 -o $O/depth -q \
  --note "Report figures 17-20 at 64x64 and 1 spp (the report: 400x400, 4 spp; its 4 bounces took 24 hours)."

# Figures 21-24: 0, 10, 20, 30 hemisphere rays per diffuse hit.
$R compare $S -i fixed-depth --sweep branching=0,10,20,30 --spp 4 --size 200x200 -o $O/branching -q \
  --note "Report figures 21-24 at 200x200 (half the report's 400x400 per side), 4 spp, depth 2, 7x7 shadow rays."

echo "wrote $O/{equal-time,shadow-grid,depth,branching}/index.html"
