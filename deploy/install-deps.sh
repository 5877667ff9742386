#!/usr/bin/env bash
# Installs every Debian 12 package prismfarm needs to build, test and run.
# Idempotent and non-interactive; run as root or as a user with sudo.
# usage: deploy/install-deps.sh [--test]
#   --test  also the packages only the tests use (deploy/test.sh passes it): Slurm's daemons and
#           munge for test_slurm_sbatch (tests/deploy/test_slurm.sh), Prometheus for
#           test_prometheus_scrape (tests/deploy/test_prometheus.sh), Chromium and its WebDriver
#           for test_dashboard_browser (tests/browser/test_dashboard.py). They are daemons and a
#           browser of some 300 MB, so a machine that only builds and renders (deploy/demo.sh,
#           the container, a farm host) does not get them; without them those tests skip
#           with the reason (CI requires them to run).
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  libzmq3-dev libmsgpack-dev libopenexr-dev openexr libembree-dev
  libpng-dev libstb-dev zlib1g-dev libjansson-dev libsodium-dev libblosc-dev
  libcmocka-dev libsqlite3-dev
  libmicrohttpd-dev
  python3
  gnuplot-nox
  clang libclang-rt-14-dev
  iproute2
  python3-numpy python3-openimageio
)
TEST_PACKAGES=(slurmctld slurmd slurm-client munge prometheus chromium chromium-driver)

case "${1:-}" in
  --test) PACKAGES+=("${TEST_PACKAGES[@]}") ;;
  "") ;;
  *) echo "usage: deploy/install-deps.sh [--test]" >&2; exit 2 ;;
esac

if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1; then
  SUDO=(sudo)
else
  echo "install-deps: run as root or install sudo" >&2
  exit 1
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
