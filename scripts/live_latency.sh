#!/usr/bin/env bash
# How long after a save `raylab render --watch` begins and ends its first new pass, per kind
# of edit, on Mitsuba's Cornell box with the 1.31 M-triangle displaced icosphere (subdivision
# 8), a small box and two instances of an icosphere asset, at 256x256 with `path` (max depth 7)
# on every core. Each edit is saved RUNS times (by writing a temporary file and renaming it over
# the scene, as editors do); the table gives the medians of what the `reload:` lines say:
#   engine   the reload itself: parse, apply the edit to the world, rebuild what it needs;
#   began    from the save (the first file event) to the new render's first pass starting,
#            which includes the watcher's 25 ms debounce;
#   ended    from the save to that pass's end (the pass at 256x256 is most of it).
# The "full load" row is the session's first load: what every save cost before the world was
# kept (plus the 150 ms debounce of then).
# Usage: scripts/live_latency.sh [BINARY] [RUNS]
set -euo pipefail
bin=$(realpath "${1:-target/release/raylab}")
runs=${2:-5}
dir=$(mktemp -d)
pid=
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
cd "$dir"

cat > base.ron <<'EOF'
(
    camera: LookAt(eye: (0, 0, 3.9), look_at: (0, 0, 0), up: (0, 1, 0), fov: 39.3077, resolution: (256, 256)),
    render: (integrator: "path", params: {"max-depth": 7}),
    materials: {
        "white": Lambert(albedo: (0.885809, 0.698859, 0.666422)),
        "green": Lambert(albedo: (0.105421, 0.37798, 0.076425)),
        "red":   Lambert(albedo: (0.570068, 0.0430135, 0.0443706)),
    },
    meshes: {"ball": Icosphere(subdivisions: 4)},
    entities: [
        (name: "floor", shape: Quad(vertices: [(-1, -1, 1), (1, -1, 1), (1, -1, -1), (-1, -1, -1)]), material: "white"),
        (name: "ceiling", shape: Quad(vertices: [(-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)]), material: "white"),
        (name: "back", shape: Quad(vertices: [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)]), material: "white"),
        (name: "green wall", shape: Quad(vertices: [(1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1)]), material: "green"),
        (name: "red wall", shape: Quad(vertices: [(-1, -1, 1), (-1, -1, -1), (-1, 1, -1), (-1, 1, 1)]), material: "red"),
        (name: "bumpy sphere", transform: (translate: (0, -0.55, 0), scale: (0.42, 0.42, 0.42)), shape: Icosphere(subdivisions: 8, displacement: 0.08), material: "white"),
        (name: "block", transform: (translate: (0.6, -0.85, 0.4), scale: (0.15, 0.15, 0.15)), shape: Box(min: (-1, -1, -1), max: (1, 1, 1)), material: "red"),
        (name: "ball A", transform: (translate: (-0.6, -0.8, 0.3), scale: (0.2, 0.2, 0.2)), shape: Instance(mesh: "ball"), material: "green"),
        (name: "ball B", transform: (translate: (0.6, -0.8, -0.5), scale: (0.2, 0.2, 0.2)), shape: Instance(mesh: "ball"), material: "white"),
        (name: "light", shape: Quad(vertices: [(-0.23, 0.99, -0.18), (0.23, 0.99, -0.18), (0.23, 0.99, 0.2), (-0.23, 0.99, 0.2)]), material: "white", emitter: Area(radiance: (18.387, 13.9873, 6.75357))),
        // added spheres
    ],
)
EOF
cp base.ron scene.ron
"$bin" render scene.ron --watch -o out.png 2> log.txt &
pid=$!

reloads() { grep -c '^reload:' log.txt || true; }
wait_for() { # PATTERN COUNT
  for _ in $(seq 600); do
    [ "$(grep -c "$1" log.txt || true)" -ge "$2" ] && return 0
    sleep 0.05
  done
  echo "timed out waiting for $1; log:" >&2; cat log.txt >&2; exit 1
}
wait_for '^load,' 1
current=$(cat base.ron)

# fields KIND: a reload line as KIND, engine ms, began ms, ended ms, what was rebuilt (tabs).
fields() {
  sed -E "s/^.*, ((built|rebuilt)[^(]*) \(([0-9.]+) ms\); first pass began ([0-9]+) ms after the save, ended after ([0-9]+) ms$/$1\t\3\t\4\t\5\t\1/"
}

# save KIND FROM TO: replaces FROM by TO in the scene, saves, waits for the reload line.
save() {
  local kind=$1 from=$2 to=$3 before
  before=$(reloads)
  current=${current/"$from"/"$to"}
  printf '%s\n' "$current" > .scene.tmp
  mv .scene.tmp scene.ron
  wait_for '^reload:' $((before + 1))
  grep '^reload:' log.txt | tail -1 | fields "$kind" >> lines.tsv
  sleep 0.3 # let a pass or two finish between saves
}

: > lines.tsv
# Each save changes one thing: a value goes from what the last save left to a new one.
colour="(0.885809, 0.698859, 0.666422)"
block="(0.6, -0.85, 0.4)"
ball="(-0.6, -0.8, 0.3)"
depth='"max-depth": 7'
bumps="displacement: 0.08"
for i in $(seq "$runs"); do
  save "material colour" "$colour" "(0.8$i, 0.698859, 0.666422)"
  colour="(0.8$i, 0.698859, 0.666422)"
  save "moved small entity" "$block" "(0.5$i, -0.85, 0.4)"
  block="(0.5$i, -0.85, 0.4)"
  save "moved instance" "$ball" "(-0.5$i, -0.8, 0.3)"
  ball="(-0.5$i, -0.8, 0.3)"
  save "added sphere" "// added spheres" "(name: \"s$i\", shape: Sphere(center: (0.$i, 0.3, 0), radius: 0.05), material: \"white\"),
        // added spheres"
  save "integrator parameter" "$depth" "\"max-depth\": $((5 + i % 2))"
  depth="\"max-depth\": $((5 + i % 2))"
  save "mesh edit (1.31 M triangles)" "$bumps" "displacement: 0.07$i"
  bumps="displacement: 0.07$i"
done
grep '^load,' log.txt | head -1 | fields "full load" >> lines.tsv

# Medians per kind, in the order the kinds first appear.
awk -F'\t' '
  function median(s,   n, a, i, j, t) {
    n = split(s, a, " ")
    for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j - 1] + 0 > a[j] + 0; j--) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  {
    kind = $1
    if (!(kind in count)) order[++k] = kind
    count[kind]++
    engine[kind] = engine[kind] " " $2; began[kind] = began[kind] " " $3; ended[kind] = ended[kind] " " $4
    what[kind] = $5
  }
  END {
    printf "| edit | saves | rebuilt | engine (ms) | first pass began (ms after save) | first pass ended (ms after save) |\n"
    printf "|---|---:|---|---:|---:|---:|\n"
    for (i = 1; i <= k; i++) {
      c = order[i]
      printf "| %s | %d | %s | %.1f | %.0f | %.0f |\n", c, count[c], what[c], median(engine[c]), median(began[c]), median(ended[c])
    }
  }' lines.tsv
