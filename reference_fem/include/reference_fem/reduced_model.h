#pragma once
// Precompute of a reduced nonlinear model (issue 50; docs/reduced-model.md): the neo-Hookean
// FEM's own law on a small basis of displacement fields, for the runtime's
// irdm::ReducedNonlinearModel. The file (docs/model-format.md, "Reduced nonlinear models")
// holds the basis at every mesh vertex, the P1 cells in the reference configuration, the
// surface with each vertex's lumped area (the FEM's node-based plane penalty), the material,
// damping and integrator; `irdm precompute --reduced` then adds a cubature (irdm/cubature.h).
//
// The basis, mass-orthonormal (U^T M U = I, M the consistent mass):
//   - the lowest `modes` eigenmodes of (K_0, M), kept whole: the linear model's slow part;
//   - the residual modes at the scene's model inputs, kept whole: the static responses to unit
//     loads there that the lowest modes miss, as the sparse route makes them, so that the
//     static compliance at the inputs (a contact's local compliance) is exact;
//   - the modal derivatives of the lowest `derivative_modes` modes (how the modes' shapes
//     change with their own amplitudes: the geometric nonlinearity's first directions, Barbic
//     and James 2005), each of unit M-norm and M-orthogonal to the modes, and their leading
//     directions by mass-weighted PCA (the eigenvectors of their M-Gram matrix), enough to make
//     `basis_size` fields in all.
// A free body (no fixed surface) has its six rigid modes first, M-orthonormal: translations
// exact, rotations linearized (a large turn strains the reduced body; the floating frame is the
// remedy, not built here). P1 elements only. Units SI.
#include <reference_fem/scene.h>

#include <functional>
#include <string>
#include <vector>

namespace irdm::fem
{
  struct ReducedModelOptions
  {
    std::string output;                // model file (.h5)
    unsigned    modes            = 20; // lowest eigenmodes, kept whole
    unsigned    derivative_modes = 8;  // modal derivatives of the lowest this many: d (d + 1) / 2
    bool        residual_modes   = true; // static responses at the scene's model inputs
    // Also the derivatives (with each other and with the derivative modes) of the first this
    // many residual modes (the most compliant): the local deformation's own quadratic terms.
    unsigned    derivative_residual_modes = 0;
    unsigned    basis_size       = 40; // r: the modes, then the derivatives' leading directions
    std::function<void(const std::string &)> log;
  };

  struct ReducedModelReport
  {
    unsigned n_dofs = 0, n_free = 0, n_vertices = 0, n_elements = 0, n_surface = 0;
    unsigned n_rigid = 0, n_modes = 0, n_residual = 0, n_derivatives = 0, basis_size = 0;
    unsigned n_strain = 0; // a free body's uniform strain fields (6), after the modes
    double   lowest_frequency_hz = 0, highest_frequency_hz = 0; // of the kept eigenmodes
    // The derivatives' mass-PCA values (their M-Gram matrix's eigenvalues, largest first, each
    // of unit M-norm), and the share of their sum the kept directions carry.
    std::vector<double> pool_values;
    double              kept_share = 1;
    double seconds_modes = 0, seconds_derivatives = 0, seconds_total = 0;
  };

  /// A press that trains a reduced model's cubature: a rigid plane of normal -direction (unit
  /// `direction` points from the body toward the plane) that touches the body where
  /// direction . x = support, moved `depth` into it over the ramp and held as long.
  struct TrainingPress
  {
    Vec3   direction;
    double support = 0, depth = 0; // m
  };

  struct FemTrainingOptions
  {
    unsigned ramp_steps = 40; // steps of the scene's tau; held as many
    unsigned every      = 4;  // a snapshot every this many steps
    std::function<void(const std::string &)> log;
  };

  struct FemTrainingStates
  {
    std::vector<std::vector<double>> states; // reduced coordinates q = U^T M u, one per snapshot
    unsigned failed_presses = 0; // Newton failed: the states before the failure are kept
    unsigned cut_steps      = 0; // steps solved again in parts
    // Of the snapshots, the largest share of the displacement's M-norm the basis misses,
    // ||u - U q||_M / ||u||_M: how far the FEM's states are from the basis.
    double largest_projection_error = 0;
    double seconds                  = 0;
  };

  /// The neo-Hookean FEM on the scene's body (its law, plane penalty and integrator; the
  /// scene's own loads, probes and planes left out) pressed by each plane in turn from rest,
  /// every `every`-th step's displacement projected on the basis U (M-orthonormal, row-major
  /// [3 v + d][k], r columns): q = U^T M u, the mass-weighted best fit. These are the FEM
  /// snapshots an ECSW cubature trains on (Farhat et al. 2014), not states of the reduced model.
  FemTrainingStates
  fem_training_states(const Scene &scene, const std::vector<double> &basis, unsigned r,
                      const std::vector<TrainingPress> &presses, const FemTrainingOptions &options);

  /// Computes the basis and writes the every-element model atomically (InputError for
  /// elements other than P1, a basis smaller than the rigid, lowest and residual modes, or
  /// larger than they and the derivatives can make).
  ReducedModelReport
  precompute_reduced_model(const Scene &scene, const ReducedModelOptions &options);
} // namespace irdm::fem
