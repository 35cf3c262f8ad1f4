#!/usr/bin/env bash
# The two axes of #50, measured: every sampler on the Cornell box (direct light and full
# paths), and every light selection on the hall of lamps, at equal samples and at equal time,
# 4 runs each; prints the tables docs/cli.md shows. Usage:
#   scripts/sampling_axes.sh [BINARY] [OUT]     (defaults: target/release/raylab, /tmp/axes)
set -euo pipefail
R=${1:-target/release/raylab}
O=${2:-/tmp/axes}
mkdir -p "$O"

table() { # metrics.json
  python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"\n{d['scene']} {d['width']}x{d['height']}, {d['budget']}, {d['runs']} runs; reference: {d['reference']}")
print("| contestant | spp | time (s) | variance | relMSE (robust) | FLIP | relMSE slope | time to unit variance |")
print("|---|---|---|---|---|---|---|---|")
best = min(r["time_to_unit_variance"] for r in d["rows"] if r["time_to_unit_variance"])
for r in d["rows"]:
    t = r["time_to_unit_variance"]
    slope = r["slope_relmse"]
    print(f"| `{r['label']}` | {r['spp']:.0f} | {r['time']:.2f} | {r['variance']:.3g} | "
          f"{r['relmse_robust']:.4g} | {r['flip']:.4f} | {'' if slope is None else f'{slope:.2f}'} | "
          f"{t:.3g} ({best / t:.2f}x the best) |")
PY
}

samplers="independent stratified sobol zsobol halton"
for integrator in direct path; do
  args=()
  for s in $samplers; do args+=(-i "$integrator@$s"); done
  for budget in "--spp 256" "--time 2"; do
    out=$O/cornell-$integrator-${budget// /}
    # shellcheck disable=SC2086
    $R compare scenes/cornell_box.ron "${args[@]}" $budget --runs 4 --size 128x128 \
      --reference-integrator "$integrator" --reference-spp 8192 -o "$out" -q
    table "$out/metrics.json"
  done
done

# The light axis on direct light (what ReSTIR estimates): light samples only, picked
# uniformly, by power, by the light BVH, and ReSTIR (its defaults: 8 candidates, 4
# neighbours), against
# one reference.
for budget in "--spp 64" "--time 4"; do
  out=$O/hall-${budget// /}
  # shellcheck disable=SC2086
  $R compare scenes/hall_of_lamps.ron -i direct --sweep light-selection=uniform,power,bvh \
    -p direct.bsdf-samples=0 $budget --runs 4 --size 160x100 --reference-integrator direct \
    -p reference.bsdf-samples=0 -p reference.light-selection=bvh --reference-spp 8192 \
    -o "$out" -q
  table "$out/metrics.json"
  # shellcheck disable=SC2086
  $R compare scenes/hall_of_lamps.ron -i restir $budget --runs 4 \
    --size 160x100 --reference "$out/reference.exr" -o "$out-restir" -q
  table "$out-restir/metrics.json"
done
