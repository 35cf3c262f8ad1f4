# Sourced by the figure scripts: `. scripts/figure_setup.sh SCENE PAGES` moves to the
# repository's root, builds the release binary and sets R (the binary), S (the scene) and
# O (the folder for the pages, created; git ignores out/).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --quiet
R=./target/release/raylab
S=$1
O=$2
mkdir -p "$O"
