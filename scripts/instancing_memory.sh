#!/usr/bin/env bash
# Instancing memory: renders N instances of a 1.31 M-triangle icosphere (subdivision 8) with
# `path` at a small size and reports peak RSS (GNU time) for N = 1 and N = 100, plus the flat
# single copy (the same mesh as an ordinary entity) for reference.
# Usage: scripts/instancing_memory.sh [raylab binary]   (default: target/release/raylab)
set -euo pipefail
bin=${1:-target/release/raylab}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

scene() { # $1 = number of instances, or "flat"
    local entities="" i
    if [ "$1" = flat ]; then
        entities='(name: "ball", transform: (scale: (0.4, 0.4, 0.4)), shape: Icosphere(subdivisions: 8, displacement: 0.05), material: "grey"),'
    else
        for ((i = 0; i < $1; i++)); do
            entities+="(name: \"ball $i\", transform: (translate: ($((i % 10)) , $((i / 10)), 0), rotate: (0, 0, $i), scale: (0.4, 0.4, 0.4)), shape: Instance(mesh: \"ball\"), material: \"grey\"),"
        done
    fi
    cat <<SCENE
(
    camera: LookAt(eye: (4.5, 4.5, 14), look_at: (4.5, 4.5, 0), up: (0, 1, 0), fov: 45, resolution: (160, 160)),
    render: (integrator: "path", spp: 4),
    materials: {"grey": Lambert(albedo: (0.6, 0.6, 0.6))},
    meshes: {"ball": Icosphere(subdivisions: 8, displacement: 0.05)},
    environment: (1, 1, 1),
    entities: [$entities],
)
SCENE
}

for n in flat 1 100; do
    scene "$n" > "$dir/balls-$n.ron"
    /usr/bin/time -v "$bin" render "$dir/balls-$n.ron" -o "$dir/balls-$n.png" 2> "$dir/time-$n.txt"
    rss=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$dir/time-$n.txt")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$dir/time-$n.txt")
    geometry=$("$bin" validate "$dir/balls-$n.ron" 2>/dev/null | awk '/memory/ {print $2, $3}')
    summary=$(grep -o '[0-9.]* s, [0-9]* threads' "$dir/time-$n.txt" | head -1)
    echo "instances $n: peak RSS $((rss / 1024)) MB, geometry + BVHs $geometry, render $summary, wall $wall"
done
