#!/usr/bin/env bash
# Installs every dependency from Debian 12 packages (run as root). Safe to run again.
# --tests: only what the build and the tests need (scripts/test.sh), without the main job's
# mesh generator and chart packages.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  libdeal.ii-dev            # deal.II 9.4 with PETSc/MUMPS, MPI, HDF5 (openmpi flavour)
  libcli11-dev              # command-line options (apps/irdm.cc)
  libeigen3-dev nlohmann-json3-dev libgtest-dev libopenblas-dev openmpi-bin libbenchmark-dev
  calculix-ccx              # a second FEM as a source of impulse responses (irdm calculix)
)
if [ "${1:-}" != --tests ]; then
  packages+=(
    gmsh                               # mesh generation (meshes/generate.sh)
    python3-matplotlib python3-numpy   # report charts (run with /usr/bin/python3)
  )
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
