# Sourced by the equal-time table scripts (after figure_setup.sh, with TIME and INTEGRATORS
# set): `reference SCENE SIZE MAX_DEPTH INTEGRATOR SPP` renders a scene's reference twice with
# independent seeds into $O/SCENE/, and `compare` with the same arguments renders every
# integrator for TIME seconds against the first and prints the second's distance from it
# (the reference's own noise).
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
