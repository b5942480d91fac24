#pragma once
// Precompute of the impulse-response model (IRDM) from the reference FEM.
//
// Convention (shared/notes/irdm-method.md section 2; docs/model-format.md): H[s] (outputs x
// inputs, m/N) is the displacement of the FEM's own discrete integrator s steps after a single
// unit force sample, from rest: with f[n] the force held during step n (impulse = f * tau),
// u[n] = sum_s H[s] f[n - s]. H[0] != 0 for the implicit integrators (direct feed-through).
// IRDM step n is the FEM state at t = (n + 1) tau when the FEM starts from rest at t = 0.
//
// Route: exact modal decoupling. With Rayleigh damping, the Newmark / generalized-alpha
// recursion of K, M, C decouples in the M-orthonormal modes of (K, M) on the free DoFs; every
// mode's response to a unit modal impulse is a scalar recursion with the same coefficients, and
// H[s] = Phi_out diag(h[s]) Phi_in^T. All modes are kept, so H equals stepping the FEM to
// round-off (tested). Runs under mpirun: inputs are split across ranks, rank 0 writes.
#include <reference_fem/scene.h>

#include <functional>
#include <optional>
#include <string>

namespace irdm::fem
{
  struct PrecomputeOptions
  {
    std::string             output;         // model file (.h5)
    std::optional<unsigned> length;         // overrides scene.model.length
    std::optional<bool>     double_storage; // overrides scene.model.storage
    unsigned                inputs_per_chunk = 0; // 0: about 64 MB of responses per chunk
    bool                    restart          = false; // ignore a resumable "<output>.part"
    bool allow_large = false; // run even if the memory or disk estimate exceeds what is free
    std::function<void(const std::string &)> log;      // progress lines (rank 0 only)
  };

  struct PrecomputeReport
  {
    unsigned n_inputs = 0, n_outputs = 0; // DoFs
    unsigned n_free = 0, length = 0, n_chunks = 0, chunks_resumed = 0;
    int      ranks          = 1;
    bool     double_storage = false;
    double   bytes          = 0; // of H
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
