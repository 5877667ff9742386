#!/usr/bin/env bash
# The main job in one command: installs dependencies, builds prismfarm (Release) and renders
# the shipped prism scene on all cores into out/prism.exr (spectral) and out/prism.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh release
build/cli/prismfarm render scenes/prism.pbrt -o out/prism.exr
echo "images: $(pwd)/out/prism.exr (spectral OpenEXR) and $(pwd)/out/prism.png (preview)"
