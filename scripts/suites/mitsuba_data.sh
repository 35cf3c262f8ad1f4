#!/usr/bin/env bash
# Tries every render-test scene of Mitsuba 3's mitsuba-data (tests/scenes/*/test_*.xml and
# the other scenes there that are not fragments or includes) with `raylab validate`, and
# prints a Markdown table: the scene, whether it loads, and the first line raylab said.
# Mitsuba's test harness adds mitsuba-data's common/ (meshes, textures) to its file
# resolver; so does this script, with `-a`.
# Usage: mitsuba_data.sh MITSUBA_DATA_CHECKOUT_OR_GIT_DIR [BINARY] [-- RAYLAB OPTIONS]
#   e.g. mitsuba_data.sh ~/mitsuba-data target/release/raylab -- --approximate
set -euo pipefail
src=${1:?a mitsuba-data checkout (or its git directory)}
bin=$(realpath "${2:-target/release/raylab}")
shift $(( $# >= 2 ? 2 : $# ))
[ "${1:-}" = "--" ] && shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -d "$src/tests/scenes" ]; then
  cp -r "$src/tests" "$src/common" "$work/"
  mkdir -p "$work/docs/scenes" && cp -r "$src/docs/scenes/sdfgrid" "$work/docs/scenes/"
else
  # A bare mirror may lack its largest files: copy each file it has (links as links), and
  # list those it has not.
  git --git-dir="$src" ls-tree -r HEAD tests common docs/scenes/sdfgrid | while read -r mode _ obj path; do
    mkdir -p "$work/$(dirname "$path")"
    if ! git --git-dir="$src" cat-file -e "$obj" 2>/dev/null; then
      echo "absent from the copy: $path" >&2
    elif [ "$mode" = 120000 ]; then
      ln -s "$(git --git-dir="$src" cat-file blob "$obj")" "$work/$path"
    else
      git --git-dir="$src" cat-file blob "$obj" > "$work/$path"
    fi
  done
fi
cd "$work"
total=0; loaded=0
echo "| scene | loads | raylab says |"
echo "|---|---|---|"
while IFS= read -r scene; do
  total=$((total + 1))
  if out=$("$bin" validate "$scene" -a "$work/common" --allow-path "$work" "$@" 2>&1); then
    loaded=$((loaded + 1))
    echo "| ${scene#tests/scenes/} | yes | $(printf '%s' "$out" | grep -m1 -i 'warning' | cut -c1-160 | tr '|' '/') |"
  else
    echo "| ${scene#tests/scenes/} | no | $(printf '%s' "$out" | grep -m1 . | sed "s|$work/||" | cut -c1-200 | tr '|' '/') |"
  fi
done < <(find tests/scenes -name '*.xml' ! -path '*/include/*' ! -path '*/fragments/*' | sort)
echo
echo "$loaded of $total scenes load"
