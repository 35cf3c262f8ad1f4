#!/usr/bin/env bash
# Equal quality on the report's room: how long `path` takes to reach the error of the
# report's own `fixed-depth` settings (400x400, 4 spp, depth 2, branching 20, 7x7 shadow
# rays). Four `compare` runs against one cached 1024-spp `path` reference: fixed-depth at
# its defaults, then path at 1, 8, 16 and 32 spp; each writes a page and metrics.csv (time, RMSE,
# FLIP, ...) under out/pages/equal-quality (git ignores out/), and the script prints the table
# that docs/performance.md shows. About 3 minutes on 2 cores.
# Usage: scripts/equal_quality.sh
. "$(dirname "$0")/figure_setup.sh" scenes/report_room.ron out/pages/equal-quality
$R compare $S -i fixed-depth --spp 4 -o $O/fixed-depth -q \
  --note "The report's fixed-depth defaults: 4 spp, depth 2, branching 20, 7x7 shadow rays."
for spp in 1 8 16 32; do
  $R compare $S -i path --spp $spp -o $O/path-$spp -q --note "path at $spp spp."
done
# One table: integrator, spp, seconds, RMSE, FLIP (columns looked up by name).
awk -F, 'FNR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
         { printf "%-12s spp %-3s %8.2f s  RMSE %.3f  relMSE %.3f  FLIP %.3f\n", $col["integrator"], $col["spp"],
           $col["time_s"], $col["rmse"], $col["rel_mse"], $col["flip"] }' \
  $O/fixed-depth/metrics.csv $O/path-1/metrics.csv $O/path-8/metrics.csv $O/path-16/metrics.csv \
  $O/path-32/metrics.csv
echo "wrote the pages in $O"
