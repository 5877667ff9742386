#!/usr/bin/env bash
# The main job in one command: installs dependencies, builds the prismfarm binary (Release; the
# tests, fuzzers and benches are left to deploy/test.sh) and renders the shipped jewel scene (a
# diamond in a gold setting: its fire, the rainbow caustic it throws on the wall, the gold) at
# the scene file's own settings (a photon pass, then the camera pass), on all cores,
# into out/jewel.exr (spectral) and out/jewel.png. What that costs is measured in one place:
# docs/performance.md, "The demo".
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh release prismfarm
# out/ is not in the repository: a fresh clone has none, and render does not make folders.
mkdir -p out
build/cli/prismfarm render scenes/jewel.pbrt -o out/jewel.exr
echo
echo "images: $(pwd)/out/jewel.exr (spectral OpenEXR) and $(pwd)/out/jewel.png (preview)"
echo "the binary is $(pwd)/build/cli/prismfarm; next, for example:"
echo "  build/cli/prismfarm render scenes/crystal.pbrt -o out/crystal.exr"
