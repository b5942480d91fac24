#pragma once
// A discrete state-space model identified from the impulse responses alone (issue 51): the
// eigensystem realization algorithm (Ho and Kalman 1966; Juang and Pappa 1985), documented in
// docs/compression.md.
//
// Convention (the impulse-response file's): f[n] the force held during step n (impulse =
// f * time_step), u[n] = sum_s H[s] f[n - s]. A realization of order r stands for
//     x[n + 1] = A x[n] + B f[n],   u[n] = C x[n] + D f[n],
// so H[0] = D (the feed-through, kept exactly) and H[s] = C A^(s-1) B for s >= 1. A is held in
// real block-diagonal form: its real eigenvalues first, then each complex pair a +- ib as the
// 2 x 2 block [a b; -b a], so a step costs O(r) for A. Every eigenvalue lies strictly inside
// the unit circle (enforced: the realization is stable by construction).
#include <irdm/model.h>
#include <irdm_common/files.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace irdm
{
  struct EraOptions
  {
    unsigned order = 400; // r, states kept (the largest Hankel singular values)
    // The responses are first projected onto dominant directions (the leading singular vectors
    // of [H[1] ... H[L]], L the samples the Hankel matrix uses): inputs onto this many (0:
    // every input, up to 1000), outputs onto the input vertices' own DoFs (kept exactly: the
    // contact rows) and this many more.
    unsigned input_directions  = 0;
    unsigned output_directions = 60;
    // Block rows (of output directions) and block columns (of input directions) of the Hankel
    // matrix, which holds samples 1 .. rows + columns; 0: about 4000 scalar rows, columns,
    // as many as the response length allows.
    unsigned hankel_rows = 0, hankel_columns = 0;
    // Eigenvalues of A beyond this radius are pulled onto it (at most 1 - 1e-9).
    double stability_radius = 0.9999;
    std::function<void(const std::string &)> log; // progress lines
  };

  struct StateSpaceModel : ModelFrame
  {
    unsigned order  = 0; // r = n_real + 2 n_pairs
    unsigned n_real = 0; // real eigenvalues, states 0 .. n_real - 1
    std::vector<double> real_poles;    // [n_real]
    std::vector<double> complex_poles; // [pair][2]: a, b of the block [a b; -b a] (b > 0)
    std::vector<double> b;             // [input DoF][state]: B's columns, contiguous
    // C = output_basis c: the outputs are y = c x in `output_dimension` directions, and
    // u = output_basis y. The first directions are the input vertices' own output DoFs
    // (unit vectors), so an input DoF's output is one row of c (contact_direction).
    // output_basis empty: the identity (the directions are the outputs themselves).
    unsigned              output_dimension = 0;
    std::vector<float>    output_basis;      // [output DoF][direction] (orthonormal)
    std::vector<float>    c;                 // [direction][state]
    std::vector<unsigned> contact_direction; // [input DoF]: the direction of its output
    std::vector<double>   d;                 // [input DoF][output DoF]: H[0]

    // How it was made.
    std::string         source_file, method = "era"; // or "balanced_truncation"
    // What ERA saw: "H as stored", or H with noise added (irdm compress --noise).
    std::string         identified_from = "H as stored";
    unsigned            input_directions = 0, output_directions = 0;
    unsigned            hankel_rows = 0, hankel_columns = 0;
    double              stability_radius = 0, identification_seconds = 0;
    unsigned            poles_pulled_in  = 0; // eigenvalues moved onto the stability radius
    std::vector<double> hankel_singular_values; // every one computed, descending
    // Balanced truncation: every nonzero Hankel singular value is in the list (the bound on the
    // truncation's miss is then known). Not stored in the file.
    bool                singular_values_complete = false;

    unsigned
    n_pairs() const
    {
      return (order - n_real) / 2;
    }
    /// H[s] at (input DoF k, output DoF j) as the realization gives it.
    double
    response(unsigned k, unsigned s, unsigned j) const;
    /// Bytes held for the runtime (poles, B, C and its basis in float, D).
    double
    bytes() const;
  };

  /// Identifies a realization of order options.order from the model's H (InputError for a
  /// model without H, an order the data cannot support, or a realization that cannot be put in
  /// block-diagonal form).
  StateSpaceModel
  identify_era(const ImpulseResponseModel &model, const EraOptions &options);

  /// What every order of one identification shares: the projections and the Hankel matrix's
  /// leading singular triplets, computed once up to options.order (the largest order a
  /// realization of it may take), so that a search over the order pays for one SVD.
  struct EraHankel;
  std::shared_ptr<const EraHankel>
  prepare_era(const ImpulseResponseModel &model, const EraOptions &options);
  /// The realization of order r <= the prepared order (identify_era = prepare, then realize).
  StateSpaceModel
  realize_era(const ImpulseResponseModel &model, const EraHankel &hankel, unsigned order);

  /// Balanced truncation of the model's own modal realization (Moore 1981; discrete time,
  /// the square-root method of Laub, Heath, Paige and Ward 1987), the peer of ERA for a model
  /// whose modes are known: every mode's integrator step as a 3-state block of
  ///     w[n + 1] = A_i w[n] + (A_i b_new + b_old) l_i^T f[n],   u[n] = sum_i phi_i w_i,u[n] + D f[n]
  /// (l_i the load shape at the inputs), the Gramians P = A P A^T + B B^T and Q = A^T Q A + C^T C
  /// solved block by block (a 9 x 9 system per pair of modes), P = Lp Lp^T and Q = Lq Lq^T, and
  /// the leading singular triplets of Lq^T Lp = U S V^T: the states of the largest Hankel
  /// singular values S. The truncation to r states misses H by at most 2 (s_r+1 + ... + s_n)
  /// in the spectral norm, at every sample. docs/compression.md.
  struct BalancedOptions
  {
    unsigned order            = 400;    // r, states kept (at most 3 x the modes)
    double   stability_radius = 0.9999; // as EraOptions'
    // The input vertices' own output DoFs (the contact rows, whose history the force loop reads)
    // weigh this much more than the other outputs in the observability Gramian: a rigid probe
    // divides their error by the one-step compliance, not the static one (docs/compression.md
    // measures the choice).
    double   contact_weight = 100;
    std::function<void(const std::string &)> log;
  };

  /// What every order of one truncation shares: the balancing's singular triplets up to
  /// options.order, computed once.
  struct BalancedGramians;
  std::shared_ptr<const BalancedGramians>
  prepare_balanced(const ImpulseResponseModel &model, const BalancedOptions &options);
  /// The truncation to r <= the prepared order (InputError beyond it, or where the system has
  /// fewer than r states that matter).
  StateSpaceModel
  realize_balanced(const ImpulseResponseModel &model, const BalancedGramians &gramians, unsigned r);
  /// InputError for a model without a modal realization, a free body (its rigid modes have no
  /// finite Gramian), or an order beyond 3 x the modes.
  StateSpaceModel
  balanced_truncation(const ImpulseResponseModel &model, const BalancedOptions &options);

  /// Writes `irdm-state-space-model` version 1 (docs/compression.md): the source's root
  /// attributes and groups copied through the checked reads, then the realization.
  void
  save_state_space_model(const StateSpaceModel &m, const std::string &source_file,
                         const std::string &path, OutputLock lock = {});

  /// Loads and checks one (InputError naming the file and the field at fault).
  StateSpaceModel
  load_state_space_model(const std::string &path, std::optional<double> expected_time_step = {});
} // namespace irdm
