// irdm precompute: the impulse-response model of a scene's body (HDF5); mpirun-able.
#include "../command.h"

#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm/cubature.h>
#include <irdm/reduced_nonlinear.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/reduced_model.h>
#include <reference_fem/scene.h>
#include <validation/model_sizing.h>

#include <mpi.h>

#include <cstdio>
#include <iostream>
#include <filesystem>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    struct PrecomputeArgs
    {
      std::string scene, out, storage, free_route = "modal", fit_weights = "uniform";
      unsigned    length = 0, chunk = 0, modes = 0, inertial_modes = 0;
      bool        restart = false, quiet = false, allow_large = false, every_mode_every_step = false,
                  modal_only = false;
      // --reduced: a reduced nonlinear model (reference_fem/reduced_model.h, irdm/cubature.h).
      bool     reduced = false, no_residual_modes = false;
      unsigned derivative_modes = 8, derivative_residual = 0, basis = 40, training_presses = 12;
      double   cubature_tolerance = 0.01, training_depth = 0.02;
      std::string training_source = "reduced";
      // --tolerance: the smallest model within it on the scene's own probes.
      double      tolerance = 0;
      std::string size_by   = "modes";
    };

    // The cubature's training states from the neo-Hookean FEM: the reduced model's own
    // presses (the same draws) run on the FEM, each snapshot projected on the basis.
    irdm::TrainingSet
    fem_training(const irdm::fem::Scene &scene, const irdm::ReducedNonlinearModel &every,
                 const irdm::TrainingOptions &t)
    {
      irdm::TrainingSet                       out = irdm::training_presses(every, t);
      std::vector<irdm::fem::TrainingPress> presses;
      for (size_t p = 0; p < out.depths.size(); ++p)
        presses.push_back({out.directions[p], out.supports[p], out.depths[p]});
      irdm::fem::FemTrainingOptions o;
      o.ramp_steps = t.ramp_steps;
      o.every      = t.every;
      o.log        = t.log;
      const auto fem = irdm::fem::fem_training_states(scene, every.basis, every.size, presses, o);
      for (const auto &q : fem.states)
        out.states.push_back(Eigen::Map<const Eigen::VectorXd>(q.data(), static_cast<Eigen::Index>(q.size())));
      out.source       = "fem";
      out.failed_steps = fem.failed_presses;
      std::printf("FEM training: %zu snapshots of %zu presses (%u failed, %u steps cut back), the "
                  "basis missing at most %.3g of a snapshot's M-norm, %.1f s\n",
                  fem.states.size(), presses.size(), fem.failed_presses, fem.cut_steps,
                  fem.largest_projection_error, fem.seconds);
      return out;
    }

    // The reduced model: the every-element file from the FEM, then (unless the tolerance is 0)
    // its cubature trained on the every-element model's presses, written to --out.
    int
    run_precompute_reduced(const PrecomputeArgs &a)
    {
      int ranks = 1;
      MPI_Comm_size(MPI_COMM_WORLD, &ranks);
      if (ranks > 1)
        throw irdm::InputError("--reduced runs on one rank: run it without mpirun");
      irdm::check_output_file("--out", a.out, {a.scene});
      const auto scene = irdm::fem::read_scene(a.scene);
      const auto log   = stderr_log(a.quiet);
      irdm::fem::ReducedModelOptions o;
      o.modes            = a.modes > 0 ? a.modes : 20;
      o.derivative_modes = a.derivative_modes;
      o.derivative_residual_modes = a.derivative_residual;
      o.residual_modes   = !a.no_residual_modes;
      o.basis_size       = a.basis;
      o.log              = log;
      const bool cubature = a.cubature_tolerance > 0;
      // The every-element model goes to a scratch file next to --out when a cubature follows.
      o.output = cubature ? a.out + ".every_element.h5" : a.out;
      struct Scratch
      {
        std::string path;
        ~Scratch()
        {
          if (!path.empty())
            std::filesystem::remove(path);
        }
      } scratch{cubature ? o.output : std::string()};
      const auto r = irdm::fem::precompute_reduced_model(scene, o);
      std::printf("reduced basis: %u fields = %u rigid modes + %u lowest modes (%.3g to %.3g Hz) + "
                  "%u residual modes + %u uniform strain fields + %u directions of %u modal "
                  "derivatives (mass-PCA share kept %.4f); %u elements, %u surface vertices; %.2f s\n",
                  r.basis_size, r.n_rigid, r.n_modes, r.lowest_frequency_hz, r.highest_frequency_hz,
                  r.n_residual, r.n_strain, r.basis_size - r.n_rigid - r.n_modes - r.n_residual - r.n_strain,
                  r.n_derivatives,
                  r.kept_share, r.n_elements, r.n_surface, r.seconds_total);
      if (!cubature)
        {
          std::printf("model %s: every element (no cubature)\n", a.out.c_str());
          return 0;
        }
      const irdm::ReducedNonlinearModel every = irdm::load_reduced_nonlinear_model(o.output);
      irdm::TrainingOptions t;
      t.presses   = a.training_presses;
      t.max_depth = a.training_depth;
      t.log       = log;
      const irdm::TrainingSet training = a.training_source == "fem"
                                           ? fem_training(scene, every, t)
                                           : irdm::training_states(every, t);
      irdm::CubatureOptions   c;
      c.tolerance            = a.cubature_tolerance;
      c.log                  = log;
      const irdm::Cubature rule = irdm::train_cubature(every, training.states, c);
      irdm::write_cubature_model(o.output, a.out, rule, training);
      std::printf("model %s: cubature of %zu of %u elements, training residual %.3g over %u "
                  "states of %u presses of the %s (up to %.3g m; %lu steps failed), %.2f s\n",
                  a.out.c_str(), rule.elements.size(), r.n_elements, rule.training_error,
                  rule.n_states, t.presses, training.source == "fem" ? "FEM" : "reduced model",
                  t.max_depth, training.failed_steps, rule.seconds);
      return 0;
    }

    // --tolerance: the modes or the length sized on the scene's probes (validation/model_sizing.h).
    int
    run_precompute_within(const PrecomputeArgs &a, const irdm::fem::PrecomputeOptions &o)
    {
      int ranks = 1;
      MPI_Comm_size(MPI_COMM_WORLD, &ranks);
      if (ranks > 1)
        throw irdm::InputError("--tolerance runs on one rank: run it without mpirun");
      if (a.modes > 0 || a.modal_only)
        throw irdm::InputError("--tolerance chooses the modes itself: leave out --modes and --modal-only");
      irdm::OutputLock lock(a.out);
      const auto what = a.size_by == "length" ? irdm::validation::PrecomputeSize::length
                                              : irdm::validation::PrecomputeSize::modes;
      static std::ostream silent(nullptr);
      const auto sized = irdm::validation::precompute_within_tolerance(
        a.scene, what, a.tolerance, o, a.quiet ? silent : std::cerr);
      for (const auto &t : sized.tried)
        std::printf("%s %.0f: force %.4g, displacement %.4g against the every-mode model%s\n",
                    a.size_by.c_str(), t.setting, t.force_error, t.displacement_error,
                    t.stable ? "" : " (unstable)");
      if (what == irdm::validation::PrecomputeSize::modes)
        std::printf("model %s: %s within %.4g on the scene\n", a.out.c_str(),
                    sized.size == 0 ? "every mode (no fewer lowest modes of the grid)"
                                    : ("the lowest " + std::to_string(sized.size) +
                                       " modes and the residual modes").c_str(),
                    a.tolerance);
      else
        std::printf("model %s: T = %u samples, the shortest of the grid within %.4g on the scene\n",
                    a.out.c_str(), sized.size, a.tolerance);
      return 0;
    }

    int
    run_precompute(const PrecomputeArgs &a)
    {
      if (a.reduced)
        return run_precompute_reduced(a);
      irdm::check_output_file("--out", a.out, {a.scene});
      const auto scene = irdm::fem::read_scene(a.scene);
      irdm::fem::PrecomputeOptions o;
      o.output = a.out;
      if (a.length > 0)
        o.length = a.length;
      o.inputs_per_chunk = a.chunk;
      if (a.modes > 0)
        o.modes = a.modes;
      if (a.inertial_modes > 0)
        o.inertial_modes = a.inertial_modes;
      o.double_storage   = storage_choice(a.storage);
      o.restart          = a.restart;
      o.allow_large      = a.allow_large;
      o.every_mode_every_step = a.every_mode_every_step;
      o.modal_only       = a.modal_only;
      o.free_route       = a.free_route == "rigid_fit" ? irdm::fem::FreeBodyRoute::rigid_fit
                                                       : irdm::fem::FreeBodyRoute::modal;
      o.fit_weights      = a.fit_weights == "mass" ? irdm::fem::RigidFitWeights::mass
                                                   : irdm::fem::RigidFitWeights::uniform;
      o.log              = stderr_log(a.quiet);
      if (a.tolerance > 0)
        return run_precompute_within(a, o);
      const auto r = irdm::fem::precompute_impulse_responses(scene, o);
      if (mpi_rank() == 0 && r.sparse)
        std::printf("sparse route: the lowest %u of %u modes (largest relative residual %.2g, %u "
                    "block solves) + %u residual modes; static compliance at the inputs in the "
                    "lowest: mean %.4f, least %.4f; with the residual modes: error %.2g\n",
                    r.n_lowest, r.n_free, r.eigen_residual, r.eigen_iterations,
                    r.n_modes - r.n_lowest, r.static_in_modes_mean, r.static_in_modes_min,
                    r.static_basis_error_max);
      if (mpi_rank() == 0)
        std::printf("model %s: %u outputs x %u inputs x %u samples, %s, %d rank(s); "
                    "%u free DoFs, %s route, %u modes\n"
                    "time: total %.2f s = FEM %.2f + modes %.2f + responses %.2f + write %.2f "
                    "(+ other)\nenergy left after T: mean %.3g, max %.3g; static compliance beyond T: "
                    "mean %.3g, max %.3g\n",
                    o.output.c_str(), r.n_outputs, r.n_inputs, r.length,
                    r.modal_only ? "modal realization only (no H)"
                                 : (irdm::fmt(r.bytes / 1e6, "%.1f") + " MB of H (" +
                                    (r.double_storage ? "double" : "float") + ")").c_str(),
                    r.ranks, r.n_free,
                    r.sparse ? "sparse" : "dense", r.n_modes, r.seconds_total,
                    r.seconds_fem, r.seconds_eigen, r.seconds_responses, r.seconds_write,
                    r.energy_left_mean, r.energy_left_max, r.static_left_mean, r.static_left_max);
      return 0;
    }
  } // namespace

  Command
  add_precompute(CLI::App &app)
  {
    auto pre = std::make_shared<PrecomputeArgs>();
    auto *precompute = app.add_subcommand("precompute", "impulse-response model of the scene's body (HDF5); mpirun-able");
    precompute->footer("Computes the impulse-response model H[s] of the scene's body (mesh, material, damping, "
      "fixed surfaces, integrator and time step tau = the scene's step) by exact modal "
      "decoupling of the reference FEM's own integrator, and writes it to an HDF5 file "
      "(docs/model-format.md). Inputs, outputs, length T and storage come from the scene's "
      "\"model\" section (default: every free surface vertex DoF in and out, T = 500, float). "
      "Under 'mpirun -np N' the inputs are split across ranks; the file is the same as a "
      "serial run's. An interrupted run leaves MODEL.h5.part and the next run with the same "
      "spec resumes it; a second run to the same --out while one is running is refused.");
    precompute->add_option("scene", pre->scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    precompute->add_option("--out", pre->out, "model file to write")->required();
    precompute->add_option("--length", pre->length, "samples per response T (overrides the scene)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--storage", pre->storage, storage_help)
      ->check(CLI::IsMember({"float", "double"}));
    precompute->add_option("--chunk", pre->chunk,
                           "inputs per chunk (default: about 64 MB of responses; clamped to the "
                           "number of inputs)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--modes", pre->modes,
                           "keep the lowest MODES modes (sparse route: shift-invert block Lanczos, plus "
                           "up to two residual modes per input DoF that keep the static "
                           "compliance and the feed-through H[0] at the inputs exact; default: "
                           "all modes by the dense route up to 12000 free DoFs, else 200)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--free-route", pre->free_route,
                           "free body (no fixed surface): how the rigid motion leaves the "
                           "response; modal: the 6 rigid-body modes dropped (mass-orthogonal, "
                           "route 2); rigid_fit: the whole response minus its best rigid fit at "
                           "every sample (the seed's, route 1; dense route only, without --modes)")
      ->check(CLI::IsMember({"modal", "rigid_fit"}))
      ->capture_default_str();
    precompute->add_option("--fit-weights", pre->fit_weights,
                           "rigid_fit: least-squares weights over the output vertices (uniform: "
                           "the seed's; mass: each vertex's lumped mass)")
      ->check(CLI::IsMember({"uniform", "mass"}))
      ->capture_default_str();
    precompute->add_option("--inertial-modes", pre->inertial_modes,
                           "free body (either route): store the inertial couplings of the lowest "
                           "N elastic modes (9 N^2 numbers), on which the runtime's Euler, "
                           "spin-softening and Coriolis forces act (default: " +
                             std::to_string(irdm::fem::default_inertial_modes) +
                             ", or every mode if fewer)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--tolerance", pre->tolerance,
                           "write the smallest model whose closed loop on the scene's own probes "
                           "keeps the probe force (relative L2) and the surface displacement "
                           "(relative RMS) within this fraction of the every-mode model's (dense "
                           "route, the scene's or --length's T): fewer lowest modes (--size-by "
                           "modes: 10, 25, 50, ... with the residual modes) or a shorter length "
                           "(--size-by length: 50, 100, 150, ...); one rank")
      ->check(CLI::Range(1e-12, 0.999));
    precompute->add_option("--size-by", pre->size_by, "with --tolerance: what is sized")
      ->check(CLI::IsMember({"modes", "length"}))
      ->capture_default_str();
    precompute->add_flag("--restart", pre->restart, "ignore a partial file and start over");
    precompute->add_flag("--allow-large", pre->allow_large,
                         "run even if the memory or disk estimate exceeds what is free");
    precompute->add_flag("--every-mode-every-step", pre->every_mode_every_step,
                         "sum every mode at every step (default: a mode is left out once its "
                         "terms stay below a tenth of the storage's round-off of the largest "
                         "response; see the file's /impulse_response/H attributes)");
    precompute->add_flag("--modal-only", pre->modal_only,
                         "write the modal realization (/modes) without H (format version 3): "
                         "for models whose H would not fit (inputs x T x outputs); only the "
                         "modal runtime reads it (irdm play, validate-converged)");
    auto *reduced = precompute->add_flag(
      "--reduced", pre->reduced,
      "a reduced nonlinear model instead (docs/reduced-model.md): the neo-Hookean law on a basis "
      "of the lowest --modes (default 20) eigenmodes and the residual modes at the scene's model "
      "inputs, then the leading mass-PCA directions of the modal derivatives of the lowest "
      "--derivative-modes, --basis fields in all; internal force by a cubature trained on "
      "presses from random directions (P1; a free body's basis has its six rigid modes first)");
    precompute->add_option("--derivative-modes", pre->derivative_modes,
                           "--reduced: modal derivatives of the lowest this many modes (d (d + 1) / 2)")
      ->check(CLI::Range(0u, 100u))->capture_default_str()->needs(reduced);
    precompute->add_option("--derivative-residual-modes", pre->derivative_residual,
                           "--reduced: modal derivatives of the first this many residual modes too "
                           "(with each other and with the derivative modes)")
      ->check(CLI::Range(0u, 10000u))->capture_default_str()->needs(reduced);
    precompute->add_option("--basis", pre->basis, "--reduced: basis size r")
      ->check(CLI::Range(1u, 2000u))->capture_default_str()->needs(reduced);
    precompute->add_flag("--no-residual-modes", pre->no_residual_modes,
                         "--reduced: no residual modes at the inputs")->needs(reduced);
    precompute->add_option("--cubature-tolerance", pre->cubature_tolerance,
                           "--reduced: relative residual of the training forces the cubature "
                           "reaches (0: every element, no cubature)")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str()->needs(reduced);
    precompute->add_option("--training-presses", pre->training_presses,
                           "--reduced: presses (random directions, fixed seed) whose states train the cubature")
      ->check(CLI::Range(1u, 10000u))->capture_default_str()->needs(reduced);
    precompute->add_option("--training-depth", pre->training_depth,
                           "--reduced: the presses' largest depth (m; each is drawn between 0.2 and 1 times it)")
      ->check(CLI::PositiveNumber)->capture_default_str()->needs(reduced);
    precompute->add_option("--training-source", pre->training_source,
                           "--reduced: what runs the training presses: the every-element reduced "
                           "model itself (reduced) or the neo-Hookean FEM, each snapshot projected "
                           "on the basis (fem)")
      ->check(CLI::IsMember({"reduced", "fem"}))->capture_default_str()->needs(reduced);
    for (const char *other : {"--length", "--storage", "--chunk", "--free-route", "--fit-weights",
                              "--inertial-modes", "--restart", "--allow-large",
                              "--every-mode-every-step", "--modal-only"})
      reduced->excludes(other);
    precompute->add_flag("--quiet", pre->quiet, "no progress on stderr");
    return {precompute, [pre] { return run_precompute(*pre); }, true};
  }
} // namespace irdm::cli
