#!/usr/bin/env bash
# Installs the runtime into a fresh prefix, builds examples/haptic_loop against the installed
# package (outside the source and build trees: find_package(irdm) must be all it needs), and
# runs it on a small model made by the irdm CLI. Only the public API's headers are installed.
# The example exits 0 only if the surface its deformation thread computed reproduces the
# prescribed probe displacement to 1e-6 (the surface shapes are stored in float).
#   install_example.sh BUILD_DIR SOURCE_DIR IRDM_CLI MESH_DIR
set -euo pipefail
build=$1 source=$2 cli=$3 meshes=$4
work=$(mktemp -d /tmp/irdm-install-test.XXXXXX)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/lib/cmake/irdm/irdmConfig.cmake"
# The public API and nothing else (docs/runtime-api.md): the runtime's parts stay in the tree.
installed=$(cd "$work/prefix/include" && find . -name '*.h' | sort | tr '\n' ' ')
expected="./irdm/irdm.h ./irdm/surface_exchange.h ./irdm_common/error.h "
if [ "$installed" != "$expected" ]; then
  echo "installed headers: $installed; expected: $expected" >&2; exit 1
fi
cat > "$work/beam.json" <<JSON
{"format": "irdm-scene/1", "name": "install_beam", "mesh": {"file": "$meshes/beam_2.msh"},
 "fe_degree": 1, "material": {"youngs_modulus_Pa": 2e5, "poisson_ratio": 0.4, "density_kg_m3": 1100},
 "damping": {"ratios": [0.05, 0.05], "frequencies_Hz": [0.5, 20]},
 "integrator": {"type": "generalized_alpha", "rho_inf": 0.8},
 "time": {"step_s": 0.002, "duration_s": 0.2}, "fixed_surfaces": ["clamp"],
 "model": {"length": 100, "storage": "double",
           "inputs": {"within": {"center_m": [0.22, 0.0, 0.01], "radius_m": 0.03}}}}
JSON
env -i PATH=/usr/bin:/bin HOME=/tmp "$cli" precompute "$work/beam.json" --out "$work/beam.h5" --quiet
cmake -S "$source/examples/haptic_loop" -B "$work/example" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log"
cmake --build "$work/example" > "$work/build.log"
"$work/example/haptic_loop" "$work/beam.h5" 400 0.001
