#pragma once
// Precompute of the impulse-response model (IRDM) from the reference FEM.
//
// Convention (shared/notes/irdm-method.md section 2; docs/model-format.md): H[s] (outputs x
// inputs, m/N) is the displacement of the FEM's own discrete integrator s steps after a single
// unit force sample, from rest: with f[n] the force held during step n (impulse = f * tau),
// u[n] = sum_s H[s] f[n - s]. H[0] != 0 for the implicit integrators (direct feed-through).
// IRDM step n is the FEM state at t = (n + 1) tau when the FEM starts from rest at t = 0.
//
// Routes: exact modal decoupling. With Rayleigh damping, the Newmark / generalized-alpha
// recursion of K, M, C decouples in the M-orthonormal modes of (K, M) on the free DoFs; every
// mode's response to a unit modal impulse is a scalar recursion with the same coefficients, and
// H[s] = Phi_out diag(h[s]) Phi_in^T. All modes are kept, so H equals stepping the FEM to
// round-off (tested). Beyond 12000 free DoFs (or with --modes) the sparse route keeps the
// lowest modes (block Lanczos) plus residual modes: the static responses to unit loads at the inputs
// with the lowest modes removed, diagonalized by Rayleigh-Ritz (modal truncation
// augmentation), so the static compliance at the inputs stays exact and H is still a sum of
// decoupled modes (the modal runtime runs it unchanged). Runs under mpirun: inputs are split
// across ranks, rank 0 writes. With the same vertices in and out, H[s] is symmetric
// (reciprocity): only the half from each input on is computed, the rest is filled by symmetry,
// and the stored H[s] is exactly symmetric. One rank writes a batch while the next computes.
//
// Free body (a scene that fixes no surface): K is singular, its six rigid-body
// modes have w = 0. They are dropped and H is made of the elastic modes only, which are
// M-orthogonal to every rigid motion: H is the response with its rigid part removed by the
// mass-weighted projection (the best rigid fit with mass weights, to first order), and the
// deformation it gives carries no linear or angular momentum. Its static compliance is the
// inertia-relief pseudo-inverse of K. The file stores the body's mass, centre of mass and
// inertia for the runtime's rigid-body dynamics (docs/model-format.md, version 2). That is
// route 2; route 1 (FreeBodyRoute::rigid_fit, the seed's) removes the best rigid fit over the
// outputs instead, which is not mass-orthogonal, and needs the dense route. Route 2 also runs on
// the sparse route: rigid modes from a shifted eigensolve, inertia-relief residual modes
// (ElasticDynamics::lowest_modes).
#include <reference_fem/scene.h>

#include <functional>
#include <optional>
#include <string>

namespace irdm::fem
{
  /// How a free body's precompute takes the rigid motion out of its response (issue 14).
  enum class FreeBodyRoute
  {
    // Route 2: the six rigid-body modes dropped; the elastic modes are mass-orthogonal to
    // every rigid motion (the deformation carries no momentum).
    modal,
    // Route 1, the seed's: the FEM's whole response (rigid modes included) minus, at every
    // sample, its best rigid fit over the output vertices by weighted least squares. The linear
    // FEM's rigid motions are infinitesimal (t + theta x r), so its best fit is the linear
    // least-squares projection onto those six fields, and the route has an exact modal
    // realization: every elastic mode's output shape with its own best fit removed (the rigid
    // modes' shapes are removed whole), the load shapes unchanged. H is then not symmetric.
    rigid_fit
  };
  enum class RigidFitWeights
  {
    uniform, // every output vertex alike: the seed's least squares over corresponding nodes
    mass     // each output vertex by its lumped (row-sum) mass
  };

  inline constexpr unsigned default_inertial_modes = 300;

  struct PrecomputeOptions
  {
    std::string             output;         // model file (.h5)
    std::optional<unsigned> length;         // overrides scene.model.length
    std::optional<bool>     double_storage; // overrides scene.model.storage
    unsigned                inputs_per_chunk = 0; // 0: about 64 MB of responses per chunk
    // Lowest modes kept. Unset: all modes by the dense route (exact), or, beyond its 12000
    // free DoFs, the lowest 200 by the sparse route. Set: the lowest `modes` by the sparse
    // route (block Lanczos), plus up to two residual modes per input DoF (the static and the
    // one-step responses the lowest modes miss), so that the static compliance and the
    // feed-through H[0] at the inputs stay exact.
    std::optional<unsigned> modes;
    bool                    restart          = false; // ignore a resumable "<output>.part"
    // A sample of the input region, for studies whose figures are per input (compression is
    // per input): every k-th input vertex in mesh order, plus every input vertex within
    // `inputs_always` (for example the region a probe touches). 1: every input vertex.
    unsigned                    input_stride = 1;
    std::optional<VertexRegion> inputs_always;
    bool allow_large = false; // run even if the memory or disk estimate exceeds what is free
    // Sum every mode at every step. Default (false): a mode is left out after its last step
    // whose terms could reach a tenth of the storage's unit round-off times the largest
    // driving-point response over the number of modes (damping and the integrator's
    // dissipation end most modes' responses within tens of steps); the file states the bound.
    bool every_mode_every_step = false;
    // Write the modal realization (/modes) and not H: a file of format version 3 that only
    // the modal runtime reads (irdm::make_modal_model). For models whose H would not fit on
    // disk or in memory (inputs x T x outputs: 15 GB for a converged trace region), while the
    // realization is modes x (inputs + outputs).
    bool modal_only = false;
    // A free body on the dense route: the modes whose inertial couplings the file stores
    // (/modes/inertial_coupling, 9 r^2 numbers; the runtime's frame forces act on them). Unset:
    // the lowest default_inertial_modes, or every mode if there are fewer.
    std::optional<unsigned> inertial_modes;
    FreeBodyRoute   free_route  = FreeBodyRoute::modal;    // free bodies only
    RigidFitWeights fit_weights = RigidFitWeights::uniform; // rigid_fit only
    std::function<void(const std::string &)> log;      // progress lines (rank 0 only)
  };

  struct PrecomputeReport
  {
    unsigned n_inputs = 0, n_outputs = 0; // DoFs
    unsigned n_free = 0, length = 0, n_chunks = 0, chunks_resumed = 0;
    unsigned n_modes = 0;       // kept: n_free on the dense route, lowest + residual on the sparse
    unsigned n_lowest = 0;      // exact eigenmodes among them
    bool     sparse  = false;   // the sparse route (lowest modes + residual modes)
    bool     free_body = false; // no fixed surface: the 6 rigid-body modes are not kept
    double   rigid_w2_max = 0;  // free body: largest |w^2| of those 6, (rad/s)^2 (round-off)
    bool     rigid_fit = false; // free body, route 1 (FreeBodyRoute::rigid_fit)
    // Route 1: the share of an elastic mode's output shape its best rigid fit removes,
    // |R c_i| / |phi_i| (Euclidean over the outputs): largest and mean over the modes. Zero
    // would make route 1 route 2.
    double   rigid_fit_share_max = 0, rigid_fit_share_mean = 0;
    double   eigen_residual = 0; // sparse: largest |K x - w2 M x| / |K x| of the modes kept
    unsigned eigen_iterations = 0; // sparse: block solves of the eigensolver
    // Sparse, within seconds_eigen: the factorization of K (or K + eps M), the block Lanczos
    // and its block solves, and the residual modes (static and one-step).
    double seconds_factor = 0, seconds_lanczos = 0, seconds_solves = 0, seconds_static = 0;
    // Sparse: the share of the driving-point static compliance (K^-1)_kk the kept modes carry,
    // sum_i phi_ki^2 / w_i^2 over (K^-1)_kk: mean and least over the inputs.
    double static_in_modes_mean = 1, static_in_modes_min = 1;
    // Sparse: the largest |1 - (Phi diag(1/w^2) Phi^T)_kk / (K^-1)_kk| over the inputs with
    // every mode kept (lowest and residual): exact up to round-off.
    double static_basis_error_max = 0;
    int      ranks          = 1;
    bool     double_storage = false;
    double   bytes          = 0; // of H (0 when modal_only)
    bool     modal_only     = false; // H not written (PrecomputeOptions::modal_only)
    double   gemm_work = 1; // the responses' GEMM over that of all modes at every step (live_modes)
    double   seconds_fem = 0, seconds_eigen = 0, seconds_responses = 0, seconds_write = 0,
           seconds_total = 0;
    // Energy (kinetic + strain) left at step T after a unit impulse, relative to the energy
    // at step 1, once the impulse is delivered: largest and mean over the inputs. Tells whether T truncates.
    double energy_left_max = 0, energy_left_mean = 0;
    // Driving-point static compliance not captured by the first T samples, |1 - sum_{s<T}
    // H_kk[s] / (K^-1)_kk|: largest and mean over the inputs. Tells whether T truncates a held
    // load (slow modes matter here far more than in the energy).
    double static_left_max = 0, static_left_mean = 0;
    double lowest_frequency_hz = 0, highest_frequency_hz = 0;
    double lowest_damping_ratio = 0;
  };

  /// Computes the model for a scene (its model section chooses inputs, outputs, T, storage) and
  /// writes it atomically. Resumes a "<output>.part" left by an interrupted run with the same
  /// spec. Collective over MPI_COMM_WORLD.
  PrecomputeReport
  precompute_impulse_responses(const Scene &scene, const PrecomputeOptions &options);
} // namespace irdm::fem
