#!/usr/bin/env bash
# The main job in one command: installs dependencies, builds prismfarm (Release) and runs it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh release
bin=build/client/prismfarm
"$bin" --help
echo
"$bin" glass N-BK7
