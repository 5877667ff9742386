#!/usr/bin/env bash
# The main job in one command: installs dependencies, builds prismfarm (Release) and renders
# the shipped jewel scene (a diamond in a gold setting: fire, gold, a caustic) on all cores into
# out/jewel.exr (spectral) and out/jewel.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh release
build/cli/prismfarm render scenes/jewel.pbrt -o out/jewel.exr
echo "images: $(pwd)/out/jewel.exr (spectral OpenEXR) and $(pwd)/out/jewel.png (preview)"
