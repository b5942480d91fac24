// irdm: one command-line program with subcommands, parsed by CLI11 (typed options with ranges:
// "--max-delay 10.9" is refused, never truncated). Exit status (docs/exit-codes.md): 0 ok,
// 1 internal error, 2 bad input, usage or a refusal, 3 a check failed, 4 a read or write failed.
#include <irdm/model.h>
#include <irdm/representative_model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/virtual_dof.h>
#include <reference_fem/scene.h>
#include <validation/converged_validation.h>
#include <validation/fem_verification.h>
#include <validation/free_body_validation.h>
#include <validation/plane_validation.h>
#include <validation/point_validation.h>

#include "play.h"

#include <deal.II/base/mpi.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <iostream>
#include <string>
#include <vector>

namespace
{
  // "  45 %, 12 s elapsed, about 15 s left" (the estimate assumes the rest goes as fast).
  void
  print_progress(const double fraction)
  {
    using Clock                = std::chrono::steady_clock;
    static const auto start    = Clock::now();
    const double      elapsed  = std::chrono::duration<double>(Clock::now() - start).count();
    const double      left     = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0;
    std::fprintf(stderr, "\r  %3.0f %%, %.0f s elapsed, about %.0f s left   ", 100 * fraction,
                 elapsed, left);
    if (fraction >= 1)
      std::fprintf(stderr, "\n");
  }

  std::function<void(const std::string &)>
  stderr_log(const bool quiet)
  {
    if (quiet)
      return {};
    return [](const std::string &s) { std::fprintf(stderr, "  %s\n", s.c_str()); };
  }

  int
  mpi_rank()
  {
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    return rank;
  }

  /// The scene's output folder, checked before the work; a word if there is none.
  void
  check_scene_outputs(const irdm::fem::Scene &scene)
  {
    if (scene.outputs.directory.empty())
      std::fprintf(stderr, "note: the scene has no outputs.directory, so nothing is written "
                           "(only the summary below)\n");
    else
      irdm::check_output_folder("outputs.directory", scene.outputs.directory);
  }

  // ---- the commands, each given its parsed options ----

  struct SimulateArgs
  {
    std::string scene;
    bool        quiet = false, allow_large = false;
  };

  /// Results stream to disk in batches of `batch` samples as the run makes them: refuse a run
  /// whose batch would not fit in memory, or whose files would not fit on the disk, before it
  /// starts.
  constexpr unsigned batch = 4096;
  void
  check_simulate_size(const irdm::fem::Scene &scene, const unsigned n_dofs, const bool allow)
  {
    const double samples = irdm::fem::n_samples(scene);
    const double series  = 3.0 * (scene.outputs.vertices.size() + 2 * scene.prescribed.size() +
                                 2 * scene.probes.size() + scene.fixed_surfaces.size() +
                                 scene.planes.size()) +
                          scene.planes.size() + 5;
    const double per_sample = 8 * (series + (scene.outputs.surface ? n_dofs : 0));
    const double memory = 2 * std::min<double>(samples, batch) * per_sample; // batch + copy
    irdm::check_memory_estimate("simulate (a batch of " + std::to_string(batch) + " samples)",
                                memory, allow);
    if (!scene.outputs.directory.empty())
      irdm::check_disk_estimate("simulate's outputs", scene.outputs.directory,
                                samples * per_sample * ((scene.outputs.hdf5 ? 1 : 0) +
                                                        (scene.outputs.csv ? 3 : 0)),
                                allow);
  }

  int
  run_simulate(const SimulateArgs &a)
  {
    const auto scene = irdm::fem::read_scene(a.scene);
    check_scene_outputs(scene);
    const auto progress = a.quiet ? nullptr : print_progress;
    irdm::fem::RunResult result;
    // The outputs are written as the run makes them (batches of `batch` samples), so memory
    // does not grow with the duration; the files get their final names only at the end.
    std::unique_ptr<irdm::fem::ResultWriter> writer;
    const auto open_writer = [&](const unsigned n_dofs) {
      check_simulate_size(scene, n_dofs, a.allow_large);
      if (!scene.outputs.directory.empty())
        writer = std::make_unique<irdm::fem::ResultWriter>(scene, n_dofs, irdm::fem::n_samples(scene));
    };
    const irdm::fem::SampleSink sink = [&](const irdm::fem::RunResult &b) {
      if (writer)
        writer->append(b);
    };
    if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
      {
        irdm::fem::NonlinearElasticity fem(scene);
        open_writer(fem.n_dofs());
        std::fprintf(stderr, "%s: nonlinear (neo-Hookean), %u steps of %g s\n",
                     scene.name.c_str(), scene.n_steps(), scene.time_step);
        result = fem.run(progress, sink, batch);
      }
    else
      {
        irdm::fem::ElasticDynamics fem(scene);
        open_writer(fem.n_dofs());
        std::fprintf(stderr, "%s: %u cells, %u DoFs (P%u), %u steps of %g s\n",
                     scene.name.c_str(), fem.n_cells(), fem.n_dofs(), scene.fe_degree,
                     scene.n_steps(), scene.time_step);
        result = fem.run(progress, sink, batch);
      }
    if (writer)
      writer->finish(result);
    std::printf("setup %.3f s, factorization %.3f s, %u steps in %.3f s (%.3g ms/step)\n",
                result.setup_seconds, result.factorization_seconds, result.n_steps,
                result.stepping_seconds, 1e3 * result.stepping_seconds / result.n_steps);
    if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
      {
        std::printf("Newton: %u iterations, %u tangent factorizations\n",
                    result.newton_iterations, result.tangent_factorizations);
        if (result.cut_steps > 0)
          std::printf("cut back: %u of %u steps solved again in parts (Newton failed at the "
                      "full step), the shortest %g s\n",
                      result.cut_steps, result.n_steps, result.smallest_step);
        std::printf("energy: largest rise above the start %.3g J, largest kinetic + strain + "
                    "contact energy %.3g J\n",
                    result.energy_rise, result.energy_scale);
        // With no loads and still planes the energy can only fall: a rise beyond Newton's
        // tolerance and the penalty's kinks (the elastic bouncing ball of the tests: 2.5e-3 of
        // the scale) is the time step's (the 2 kPa cat at 2 ms: 0.34).
        bool still = scene.vertex_forces.empty() && scene.surface_forces.empty();
        for (const auto &p : scene.planes)
          still = still && p.position.times.size() <= 1 && p.normal_path.times.empty();
        if (still && result.energy_rise > 1e-2 * result.energy_scale)
          std::fprintf(stderr,
                       "warning: with no loads and planes that stand still the energy can only "
                       "fall, but it rose by %.3g of its scale: the time step is too coarse "
                       "for these strains (docs/scene-format.md); refine it\n",
                       result.energy_rise / result.energy_scale);
      }
    for (const auto &[name, tag] : result.vertex_node_tag)
      std::printf("vertex %s: node tag %lld\n", name.c_str(), static_cast<long long>(tag));
    for (const auto &[name, f] : result.probe_force)
      std::printf("probe %s: final force (%.6g, %.6g, %.6g) N\n", name.c_str(), f.back()[0],
                  f.back()[1], f.back()[2]);
    for (const auto &[name, f] : result.plane_force)
      {
        double peak = 0, deepest = -1e300;
        for (const auto &F : f)
          peak = std::max(peak, std::sqrt(F[0] * F[0] + F[1] * F[1] + F[2] * F[2]));
        for (const double p : result.plane_penetration.at(name))
          deepest = std::max(deepest, p);
        std::printf("plane %s: peak force %.6g N, deepest penetration %.4g m ", name.c_str(),
                    peak, deepest);
        // Linear kinematics touch by vertex, nonlinear by face penalty.
        const auto k = result.plane_vertex_stiffness.find(name);
        if (k == result.plane_vertex_stiffness.end())
          std::printf("(penalty %.3g Pa/m)\n", result.plane_penalty.at(name));
        else if (k->second > 0)
          std::printf("(vertex contact, %.3g N/m per vertex)\n", k->second);
        else
          std::printf("(vertex contact, rigid)\n");
      }
    if (!scene.outputs.directory.empty())
      std::printf("outputs in %s\n", scene.outputs.directory.c_str());
    return 0;
  }

  int
  run_static(const std::string &scene_file)
  {
    const auto scene = irdm::fem::read_scene(scene_file);
    check_scene_outputs(scene);
    irdm::fem::ElasticDynamics fem(scene);
    const auto r = fem.solve_static(0.0);
    std::printf("volume %.9g m^3, %u DoFs\n", fem.volume(), fem.n_dofs());
    for (const auto &[name, s] : r.fixed_reaction)
      std::printf("reaction on %s: (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                  s[0][2]);
    for (const auto &[name, s] : r.vertex_displacement)
      std::printf("vertex %s (node tag %lld): u = (%.9g, %.9g, %.9g) m\n", name.c_str(),
                  static_cast<long long>(r.vertex_node_tag.at(name)), s[0][0], s[0][1], s[0][2]);
    for (const auto &[name, s] : r.probe_force)
      std::printf("probe %s: F = (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                  s[0][2]);
    fem.write_outputs(r);
    return 0;
  }

  int
  run_modes(const std::string &scene_file, const unsigned count)
  {
    const auto scene = irdm::fem::read_scene(scene_file);
    irdm::fem::ElasticDynamics fem(scene);
    const auto f = fem.natural_frequencies(count);
    for (unsigned i = 0; i < f.size(); ++i)
      std::printf("mode %u: %.9g Hz\n", i + 1, f[i]);
    return 0;
  }

  int
  run_probe_stiffness(const std::string &scene_file, const double t)
  {
    const auto scene = irdm::fem::read_scene(scene_file);
    irdm::fem::ElasticDynamics fem(scene);
    const auto c = fem.probe_compliance(t);
    std::printf("scene %s: P%u, %u free DoFs, %u cells, cell size (V/cells)^(1/3) %.6g m\n",
                scene.name.c_str(), scene.fe_degree, fem.n_free_dofs(), fem.n_cells(),
                std::cbrt(fem.volume() / fem.n_cells()));
    for (size_t p = 0; p < scene.probes.size(); ++p)
      std::printf("probe %s: radius %.6g m, %u vertices, stiffness %.9g N/m along its direction "
                  "at (%.6g, %.6g, %.6g) m\n",
                  scene.probes[p].name.c_str(), scene.probes[p].radius, c.n_vertices[p],
                  c.stiffness[p], c.point[p][0], c.point[p][1], c.point[p][2]);
    std::printf("time: %.2f s (static factorization and solves)\n", c.seconds);
    return 0;
  }

  struct PrecomputeArgs
  {
    std::string scene, out, storage, free_route = "modal", fit_weights = "uniform";
    unsigned    length = 0, chunk = 0, modes = 0;
    bool        restart = false, quiet = false, allow_large = false, every_mode_every_step = false,
                modal_only = false;
  };

  std::optional<bool>
  storage_choice(const std::string &s)
  {
    if (s.empty())
      return std::nullopt;
    return s == "double";
  }

  int
  run_precompute(const PrecomputeArgs &a)
  {
    irdm::check_output_file("--out", a.out, {a.scene});
    const auto scene = irdm::fem::read_scene(a.scene);
    irdm::fem::PrecomputeOptions o;
    o.output = a.out;
    if (a.length > 0)
      o.length = a.length;
    o.inputs_per_chunk = a.chunk;
    if (a.modes > 0)
      o.modes = a.modes;
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

  struct PrecomputeVdofArgs
  {
    std::string scene, out, storage;
    unsigned    subdivisions = 2, length = 0;
    double      depth = 0.001, band = 0.001;
    bool        quiet = false, allow_large = false;
  };

  int
  run_precompute_vdof(const PrecomputeVdofArgs &a)
  {
    irdm::check_output_file("--out", a.out, {a.scene});
    const auto scene = irdm::fem::read_scene(a.scene);
    irdm::fem::VirtualDofOptions o;
    o.output         = a.out;
    o.subdivisions   = a.subdivisions;
    o.impulse_depth  = a.depth;
    o.band           = a.band;
    if (a.length > 0)
      o.length = a.length;
    o.double_storage = storage_choice(a.storage);
    o.allow_large    = a.allow_large;
    o.log            = stderr_log(a.quiet);
    const auto r = irdm::fem::precompute_virtual_dofs(scene, o);
    if (mpi_rank() == 0)
      std::printf("virtual DOF model %s: %u orientations x %u samples, %u surface vertices, "
                  "%d rank(s)\ntime: total %.2f s; per orientation mean %.2f s, max %.2f s "
                  "(one rank); %u Newton iterations\nimpulse forces %.4g to %.4g N\n",
                  o.output.c_str(), r.n_orientations, r.length, r.n_surface, r.ranks,
                  r.seconds_total, r.seconds_per_orientation_mean, r.seconds_per_orientation_max,
                  r.newton_iterations, r.impulse_force_min, r.impulse_force_max);
    if (mpi_rank() == 0 && r.free_body)
      std::printf("free body (no fixed surface): rigid motion taken out by the best fit, %.3g %% "
                  "of the recorded displacement on average, %.3g %% at most\n",
                  100 * r.rigid_share_mean, 100 * r.rigid_share_max);
    return 0;
  }

  struct CompressArgs
  {
    std::string               in, out;
    irdm::CompressionOptions  o;
    bool                      quiet = false;
  };

  /// compare-models: how far a model's H is from a reference model's (same inputs, outputs,
  /// step and length), e.g. a truncated or coarser-storage model against the exact one.
  int
  run_compare_models(const std::string &reference_path, const std::string &model_path)
  {
    const auto ref = irdm::load_model(reference_path);
    const auto m   = irdm::load_model(model_path, ref.time_step);
    if (m.length != ref.length || m.input_node_tags != ref.input_node_tags ||
        m.output_node_tags != ref.output_node_tags)
      throw irdm::InputError("compare-models: '" + model_path + "' and '" + reference_path +
                             "' differ in their inputs, outputs or length");
    const unsigned nin = ref.n_inputs, nout = ref.n_outputs, T = ref.length;
    double d2 = 0, r2 = 0, worst_input = 0, worst_static = 0, worst_feedthrough = 0;
    for (unsigned k = 0; k < nin; ++k)
      {
        const unsigned kk = 3 * ref.input_output_index[k / 3] + k % 3; // driving point
        double         dk = 0, rk = 0, sum_ref = 0, sum_m = 0;
        for (unsigned s = 0; s < T; ++s)
          {
            for (unsigned j = 0; j < nout; ++j)
              {
                const double a = ref.h(k, s, j), b = m.h(k, s, j);
                dk += (a - b) * (a - b);
                rk += a * a;
              }
            sum_ref += ref.h(k, s, kk);
            sum_m += m.h(k, s, kk);
          }
        d2 += dk;
        r2 += rk;
        worst_input  = std::max(worst_input, std::sqrt(dk / rk));
        worst_static = std::max(worst_static, std::abs(sum_m / sum_ref - 1));
        worst_feedthrough =
          std::max(worst_feedthrough, std::abs(m.h(k, 0, kk) / ref.h(k, 0, kk) - 1));
      }
    std::printf("%s against %s (%u inputs x %u samples x %u outputs):\n"
                "  H, relative L2 over all entries: %.3e\n"
                "  H, relative L2 of the worst input: %.3e\n"
                "  driving-point static compliance sum_s H_kk[s], worst relative: %.3e\n"
                "  driving-point feed-through H_kk[0], worst relative: %.3e\n",
                model_path.c_str(), reference_path.c_str(), nin, T, nout, std::sqrt(d2 / r2),
                worst_input, worst_static, worst_feedthrough);
    return 0;
  }

  int
  run_compress(CompressArgs a)
  {
    irdm::check_output_file("--out", a.out, {a.in});
    irdm::OutputLock lock(a.out); // before the work: a second run to --out is refused now
    a.o.log = stderr_log(a.quiet);
    const auto model = irdm::load_model(a.in);
    const auto c     = irdm::compress(model, a.o);
    irdm::save_representative_model(c, a.in, a.out, std::move(lock));
    const double waveforms = static_cast<double>(model.n_inputs) * model.n_outputs;
    std::printf("compressed %s -> %s: theta %.3g, blend %u\n"
                "waveforms %.0f: %llu representative (%.3g %%), %llu substituted; mean fit %.4f, "
                "min fit %.4f, mean delay %.2f steps, largest delay %u\n"
                "size: representatives %.2f MB + blend tables %.2f MB = %.2f MB, %.3g %% of %.1f MB "
                "(float H); time %.2f s\n",
                a.in.c_str(), a.out.c_str(), c.theta, c.blend, waveforms,
                static_cast<unsigned long long>(c.n_representative()),
                100 * c.n_representative() / waveforms,
                static_cast<unsigned long long>(c.n_substituted), c.mean_fit, c.min_fit,
                c.mean_delay, c.delay_span, c.representative_bytes() / 1e6,
                (c.bytes() - c.representative_bytes()) / 1e6, c.bytes() / 1e6,
                100 * c.bytes() / (4 * waveforms * model.length),
                4 * waveforms * model.length / 1e6, c.compression_seconds);
    return 0;
  }
} // namespace

namespace
{
  // With several MPI ranks, an error on one rank must stop all of them, not hang the rest.
  void
  abort_other_ranks()
  {
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (size > 1)
      MPI_Abort(MPI_COMM_WORLD, 2);
  }

  const char *const storage_help = "float or double (overrides the scene's model.storage)";

  int
  run(int argc, char **argv)
  {
    CLI::App app{"irdm: impulse response deformation model (IRDM) validation harness.\n"
                 "Units are SI throughout. Scene files: docs/scene-format.md; result files: "
                 "docs/fem-output.md; models: docs/model-format.md; exit codes: "
                 "docs/exit-codes.md.",
                 "irdm"};
    app.require_subcommand(1);
    app.fallthrough(false);

    // simulate
    SimulateArgs sim;
    auto *simulate = app.add_subcommand("simulate", "run a scene with the reference FEM and write its outputs");
    simulate->footer("Runs the scene with the reference FEM (P1/P2 tetrahedra, implicit Newmark or "
      "generalized-alpha) from its initial state to its duration, and writes the outputs the "
      "scene asks for (HDF5, CSV, VTU) into its output directory. \"kinematics\": \"linear\" "
      "(default) is small-strain elasticity; \"nonlinear\" is Total Lagrangian neo-Hookean "
      "elasticity with Newton at each step, rigid planes (penalty contact) and an initial "
      "velocity.");
    simulate->add_option("scene", sim.scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    simulate->add_flag("--quiet", sim.quiet, "no progress on stderr");
    simulate->add_flag("--allow-large", sim.allow_large,
                       "run even if the results' memory or disk estimate exceeds what is free");

    // static
    std::string static_scene;
    auto *stat = app.add_subcommand("static", "static equilibrium under the scene's loads at t = 0");
    stat->footer("Solves K u = f for the scene's loads (and gravity) at t = 0 with its fixed "
                "surfaces and prescribed displacements, prints the reactions and observed "
                "displacements, and writes the outputs like 'simulate' (one sample).");
    stat->add_option("scene", static_scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);

    // modes
    std::string modes_scene;
    unsigned    modes_count = 6;
    auto *modes = app.add_subcommand("modes", "lowest natural frequencies of the fixed body");
    modes->footer("Lowest natural frequencies (Hz) of the scene's body with its fixed surfaces, "
               "undamped (subspace iteration).");
    modes->add_option("scene", modes_scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    modes->add_option("--count", modes_count, "number of frequencies (at most the free DoFs)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));

    // probe-stiffness
    std::string stiffness_scene;
    double      stiffness_time = 0;
    auto *stiffness = app.add_subcommand(
      "probe-stiffness", "static driving-point stiffness of the scene's probes (N/m)");
    stiffness->footer(
      "For each probe of the scene at time --time: the static compliance S = B K^-1 B^T of its "
      "spread B (the 3 vertices of its contact triangle, or for a probe with radius_m the "
      "vertices within that radius by smooth weights) and the stiffness d^T S^-1 d along its "
      "direction d (N/m). A point probe's stiffness falls without bound as the mesh is refined "
      "(a point load); a radius probe's converges. Used by scripts/convergence.sh.");
    stiffness->add_option("scene", stiffness_scene, "scene file (JSON)")
      ->required()
      ->check(CLI::ExistingFile);
    stiffness->add_option("--time", stiffness_time, "time (s) at which the probes' contact "
                                                    "points are taken")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);

    // verify-fem
    irdm::validation::FemVerificationOptions vf;
    auto *verify = app.add_subcommand("verify-fem", "FEM verification suite against theory; writes a report");
    verify->footer("Runs the reference-FEM verification suite (cantilever frequency and convergence, static "
      "tip deflection, energy conservation and dissipation, gravity reaction, damping, "
      "prescribed displacement reaction; nonlinear mode: a ball's peak contact force against "
      "Hertz over impact speed, mesh and penalty) and writes a Markdown report with CSV data "
      "under --out; about 10 min on 2 cores (--quick: 1.5 min). Exit code 0: every check "
      "passed; 3: some check failed (the report says which).");
    verify->add_option("--meshes", vf.mesh_dir, "folder with the project's meshes")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    verify->add_option("--out", vf.report_dir, "report folder")->capture_default_str();
    verify->add_flag("--quick", vf.quick,
                     "skip the finest beam and ball meshes and most impact speeds (for a fast "
                     "look; the report says so)");

    // precompute
    PrecomputeArgs pre;
    auto *precompute = app.add_subcommand("precompute", "impulse-response model of the scene's body (HDF5); mpirun-able");
    precompute->footer("Computes the impulse-response model H[s] of the scene's body (mesh, material, damping, "
      "fixed surfaces, integrator and time step tau = the scene's step) by exact modal "
      "decoupling of the reference FEM's own integrator, and writes it to an HDF5 file "
      "(docs/model-format.md). Inputs, outputs, length T and storage come from the scene's "
      "\"model\" section (default: every free surface vertex DoF in and out, T = 500, float). "
      "Under 'mpirun -np N' the inputs are split across ranks; the file is the same as a "
      "serial run's. An interrupted run leaves MODEL.h5.part and the next run with the same "
      "spec resumes it; a second run to the same --out while one is running is refused.");
    precompute->add_option("scene", pre.scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    precompute->add_option("--out", pre.out, "model file to write")->required();
    precompute->add_option("--length", pre.length, "samples per response T (overrides the scene)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--storage", pre.storage, storage_help)
      ->check(CLI::IsMember({"float", "double"}));
    precompute->add_option("--chunk", pre.chunk,
                           "inputs per chunk (default: about 64 MB of responses; clamped to the "
                           "number of inputs)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--modes", pre.modes,
                           "keep the lowest MODES modes (sparse route: shift-invert block Lanczos, plus "
                           "up to two residual modes per input DoF that keep the static "
                           "compliance and the feed-through H[0] at the inputs exact; default: "
                           "all modes by the dense route up to 12000 free DoFs, else 200)")
      ->check(CLI::Range(1u, 1000000u));
    precompute->add_option("--free-route", pre.free_route,
                           "free body (no fixed surface): how the rigid motion leaves the "
                           "response; modal: the 6 rigid-body modes dropped (mass-orthogonal, "
                           "route 2); rigid_fit: the whole response minus its best rigid fit at "
                           "every sample (the seed's, route 1; dense route only, without --modes)")
      ->check(CLI::IsMember({"modal", "rigid_fit"}))
      ->capture_default_str();
    precompute->add_option("--fit-weights", pre.fit_weights,
                           "rigid_fit: least-squares weights over the output vertices (uniform: "
                           "the seed's; mass: each vertex's lumped mass)")
      ->check(CLI::IsMember({"uniform", "mass"}))
      ->capture_default_str();
    precompute->add_flag("--restart", pre.restart, "ignore a partial file and start over");
    precompute->add_flag("--allow-large", pre.allow_large,
                         "run even if the memory or disk estimate exceeds what is free");
    precompute->add_flag("--every-mode-every-step", pre.every_mode_every_step,
                         "sum every mode at every step (default: a mode is left out once its "
                         "terms stay below a tenth of the storage's round-off of the largest "
                         "response; see the file's /impulse_response/H attributes)");
    precompute->add_flag("--modal-only", pre.modal_only,
                         "write the modal realization (/modes) without H (format version 3): "
                         "for models whose H would not fit (inputs x T x outputs); only the "
                         "modal runtime reads it (irdm play, validate-converged)");
    precompute->add_flag("--quiet", pre.quiet, "no progress on stderr");

    // precompute-vdof
    PrecomputeVdofArgs pv;
    auto *precompute_vdof = app.add_subcommand("precompute-vdof", "virtual-DOF model (plane contact, seed 001); mpirun-able");
    precompute_vdof->footer("Virtual degrees of freedom (seed 001): for each plane orientation (the vertices of a "
      "geodesic dome), hits the scene's body once with a rigid frictionless wall in "
      "the nonlinear FEM (neo-Hookean, penalty contact) and records the responses of the "
      "surface and of every virtual DOF to that impulse, per newton of wall force "
      "(docs/model-format.md). Uses the scene's mesh, material, damping, integrator, step, "
      "fixed surfaces and model length T; loads, probes and gravity are left out. A scene "
      "with no fixed surface is a free body: its rigid motion (the best rigid fit at every "
      "sample) is taken out of the responses (route 1 of issue 14). Under "
      "'mpirun -np N' the orientations are dealt to the ranks; rank 0 writes.");
    precompute_vdof->add_option("scene", pv.scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    precompute_vdof->add_option("--out", pv.out, "model file to write")->required();
    precompute_vdof->add_option("--subdivisions", pv.subdivisions,
                                "icosahedron subdivisions: 10 * 4^S + 2 orientations")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4u));
    precompute_vdof->add_option("--depth", pv.depth,
                                "m, the wall's penetration into the undeformed body during its "
                                "one step of contact")
      ->capture_default_str()
      ->check(CLI::Range(1e-7, 0.05));
    precompute_vdof->add_option("--band", pv.band,
                                "m, vertices within B of a plane at first contact define its "
                                "virtual DOF's displacement (the seed's 1 mm)")
      ->capture_default_str()
      ->check(CLI::Range(1e-7, 0.05));
    precompute_vdof->add_option("--length", pv.length, "samples per response T (overrides the scene)")
      ->check(CLI::Range(1u, 1000000u));
    precompute_vdof->add_option("--storage", pv.storage, storage_help)
      ->check(CLI::IsMember({"float", "double"}));
    precompute_vdof->add_flag("--allow-large", pv.allow_large,
                              "run even if the memory or disk estimate exceeds what is free");
    precompute_vdof->add_flag("--quiet", pv.quiet, "no progress on stderr");

    // compress
    CompressArgs ca;
    auto *compress = app.add_subcommand("compress", "compress a model by representative waveforms (seed 000 sec. 3)");
    compress->footer("Compresses an impulse-response model (from 'irdm precompute') by representative "
      "waveforms (seed 000, section 3; docs/compression.md): every waveform H_kj is kept as a "
      "representative or replaced by representatives of the same input, delayed (d >= 0 "
      "steps) and scaled, when their correlation reaches theta. The output is a model the "
      "runtime runs directly, with the source's metadata plus theta and the statistics.");
    compress->add_option("model", ca.in, "model file from 'irdm precompute'")->required()->check(CLI::ExistingFile);
    compress->add_option("--out", ca.out, "compressed model to write")->required();
    compress->add_option("--theta", ca.o.theta, "correlation threshold in (0, 1]")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1.0));
    compress->add_option("--blend", ca.o.blend,
                         "representatives blended per waveform: 1 = plain substitution (the "
                         "seed's), 2..4 = interpolation among nearby ones")
      ->capture_default_str()
      ->check(CLI::Range(1u, 4u));
    compress->add_option("--max-delay", ca.o.max_delay, "largest delay searched, steps")
      ->capture_default_str()
      ->check(CLI::Range(0u, 65535u));
    compress->add_option("--candidates", ca.o.candidates,
                         "nearest representatives searched per waveform")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    compress->add_option("--threads", ca.o.threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1024u));
    compress->add_flag("--quiet", ca.quiet, "no progress on stderr");

    // compare-models
    std::string cmp_reference, cmp_model;
    auto *compare = app.add_subcommand("compare-models", "how far a model's H is from a reference model's");
    compare->footer("Relative differences of H between two models of the same inputs, outputs, "
      "time step and length (for example a sparse-route model with --modes against the "
      "all-modes model): over all entries, for the worst input, and of the driving-point "
      "static compliance and feed-through.");
    compare->add_option("reference", cmp_reference, "reference model (from 'irdm precompute')")
      ->required()->check(CLI::ExistingFile);
    compare->add_option("model", cmp_model, "model to compare")->required()->check(CLI::ExistingFile);

    // validate
    irdm::validation::PointValidationOptions va;
    bool no_full_model = false;
    auto *validate = app.add_subcommand("validate", "IRDM against the FEM on validation/scenes; writes reports/");
    validate->footer("Runs every scene of --scenes through the reference FEM (ground truth) and the IRDM "
      "runtime with a model precomputed for the scene, and writes reports/<scene>/report.md "
      "with CSV and charts, and a summary reports/validation.md: (a) exactness of the "
      "untruncated model (double and float), (b) error against the response length T, (c) "
      "both against the FEM at tau/10, (d) time per step of each, measured in the same run, "
      "(e) compression (docs/compression.md). With the full model it also writes the seed's "
      "Table 1 for the cat. Exit status 3 if an untruncated double model differs from the FEM "
      "by more than 1e-9.");
    validate->add_option("--scenes", va.scenes_dir, "scene folder")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    validate->add_option("--out", va.report_dir, "report folder")->capture_default_str();
    validate->add_option("--models", va.model_dir,
                         "where models are written while they are used (a file already there "
                         "is never overwritten)")
      ->capture_default_str();
    validate->add_option("--scene", va.only, "run only this scene (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    validate->add_flag("--no-full-model", no_full_model,
                       "skip the full cat model (T = 500, 4.8 GB): its precompute timing, the "
                       "seed's Table 1 and the full-model runtimes (about 5 min)");
    validate->add_option("--full-model-stride", va.full_model_stride,
                         "full model inputs: every k-th free surface vertex plus the first "
                         "scene's touched region (compression is per input, so a sample gives "
                         "its ratios at a k-th of the memory and time; 1: every vertex)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000u));
    validate->add_option("--length", va.length,
                         "samples per response of every scene's model (default: the scene's "
                         "model.length); never fewer than the scene's steps, so no run truncates")
      ->check(CLI::Range(1u, 100000u));

    // validate-planes
    irdm::validation::PlaneValidationOptions vp;
    auto *validate_planes = app.add_subcommand("validate-planes", "plane contact (virtual DOFs, many-vertex contact) against the nonlinear FEM; reports/planes");
    validate_planes->footer("Plane contact against the nonlinear reference FEM on the grounded cat, by virtual "
      "DOFs (seed 001; vdof_nearest, vdof_interpolated) and by many-vertex contact "
      "(vertex_contact_modal, vertex_contact_direct): a wall pressing from the side, from "
      "the top, from two directions between the dome's, and two walls at once, at depths 2 to "
      "20 mm; a tilted side wall turning while held, so that its contact patch slides; and "
      "hitting the side at 0.05 to 0.5 m/s (2 mm deep). Then compliant walls over "
      "--stiffness-sweep on four cases, and the orientation mappings compared (nearest, "
      "interpolated, interpolated_same_contact). Precomputes the virtual-DOF "
      "model and the every-surface-vertex model first, or reuses --model and --vertex-model "
      "when made from the same scene and spec (an existing file of another kind or spec is "
      "refused, never overwritten). Writes DIR/planes/planes.md, planes.csv (one row per case "
      "and method), cases.csv, forces.csv, stiffness.csv, mapping.csv, planes.png and "
      "stiffness.png.");
    validate_planes->add_option("--scene", vp.scene, "the body (its probes are ignored)")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
    validate_planes->add_option("--out", vp.report_dir, "report folder")->capture_default_str();
    validate_planes->add_option("--model", vp.model_file, "virtual-DOF model")->capture_default_str();
    validate_planes->add_option("--subdivisions", vp.subdivisions, "dome subdivisions")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4u));
    validate_planes->add_option("--length", vp.length,
                                "samples per response (the longest case is 0.6 s)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    validate_planes->add_option("--vertex-model", vp.vertex_model_file,
                                "many-vertex contact model (every free surface vertex)")
      ->capture_default_str();
    validate_planes->add_option("--margin", vp.margin,
                                "m; vertices within it of a wall are contact candidates")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
    validate_planes->add_option("--max-candidates", vp.max_candidates,
                                "candidate vertices per step, at most")
      ->capture_default_str()
      ->check(CLI::Range(1u, 20000u));
    validate_planes->add_option("--surface-modes", vp.surface_modes,
                                "modes of the modal surface update (the force loop uses all)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000000u));
    validate_planes->add_option("--vertex-stiffness", vp.vertex_stiffness,
                                "N/m per vertex of vertex contact's walls in the main table; "
                                "-1: the FEM penalty's per-vertex equivalent; 0: rigid")
      ->capture_default_str()
      ->check(CLI::Range(-1.0, 1e12));
    validate_planes->add_option("--stiffness-sweep", vp.stiffness_sweep,
                                "N/m; compliant-wall stiffnesses tried on the sweep cases (0: rigid)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e12));
    validate_planes->add_flag("!--no-direct", vp.direct,
                              "skip vertex_contact_direct (its H needs GBs of memory)");
    validate_planes->add_flag("--quick", vp.quick,
                              "15 of the 22 cases: every kind and the sweep's cases, at fewer "
                              "depths and speeds (the main job's default)");

    // validate-free
    irdm::validation::FreeBodyValidationOptions vfb;
    auto *validate_free = app.add_subcommand("validate-free", "the free cat dropped, tilted, spinning and thrown at a wall, against the nonlinear FEM; reports/free");
    validate_free->footer("Precomputes the free-body models of --scene (no fixed surface) by both "
      "routes (route 1: the recorded response minus its best rigid fit, uniform weights; route "
      "2: the rigid-body modes removed) for each Young's modulus of --materials, then runs every "
      "case through the nonlinear FEM (neo-Hookean, penalty planes) and FreeBodyInteraction "
      "(rigid body + modal deformation, many-vertex contact with the FEM's penalty, each "
      "vertex weighed by its lumped area; a probe's force as a known point force) with each model, and through FreeBodyVirtualDofs with the seed's virtual "
      "DOFs of the free body (irdm precompute-vdof on it; the precompute's penalty walls): drops from 2, 5 and 10 cm, a drop with a spin (2 s), a "
      "throw at a wall, a drop on a floor tilted 25 degrees, and a push by a probe (the "
      "virtual DOFs take no probe); then the runtime alone rolls "
      "for --stability seconds and flies free for 10 s. Writes DIR/free/free.csv (one row per "
      "case, material and method), first_contact.csv (the same measures over the first "
      "contact alone), truth_strain.csv (the truth's largest strain), truth.csv (with --truth-check), linearization.csv (the linear "
      "FEM against the truth, the runtime against the linear FEM), series.csv (forces, heights, angles and "
      "deformation against time), "
      "frames.csv and triangles.csv (surfaces of the rolling cat), fig6.png, frames.png and "
      "report.md. Units SI.");
    validate_free->add_option("--scene", vfb.scene, "the free body")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
    validate_free->add_option("--out", vfb.report_dir, "report folder")->capture_default_str();
    validate_free->add_option("--model-dir", vfb.model_dir, "folder of the free models (written)")
      ->capture_default_str();
    validate_free->add_option("--materials", vfb.materials,
                              "Young's moduli (Pa), space- or comma-separated")
      ->capture_default_str()
      ->delimiter(',')
      ->check(CLI::Range(1.0, 1e12));
    validate_free->add_option("--fem-divisions", vfb.fem_divisions,
                              "the truth's step: the nonlinear FEM runs at tau / M, sampled at "
                              "tau; one M for every material, or one per material of "
                              "--materials (the default: 4 for 2 kPa, 1 for 50 kPa)")
      ->capture_default_str()
      ->delimiter(',')
      ->check(CLI::Range(1u, 64u));
    validate_free->add_option("--duration", vfb.duration, "seconds per case")
      ->capture_default_str()
      ->check(CLI::Range(0.002, 100.0));
    validate_free->add_option("--surface-modes", vfb.surface_modes,
                              "modes in the surface update; 0: every mode")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--study-surface-modes", vfb.study_surface_modes,
                              "the impact study also runs route 2 with this many modes in its "
                              "surface (route2_modal_s<M>); 0: not run")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--stability", vfb.stability_seconds,
                              "seconds of rolling for the runtime's stability run")
      ->capture_default_str()
      ->check(CLI::Range(0.002, 3600.0));
    validate_free->add_flag("--quick", vfb.quick, "the 5 cm drop and the tilted drop only");
    validate_free->add_option("--force-modes", vfb.force_modes,
                              "each route also with K modes in the force loop (the rest "
                              "quasi-static): methods route1_rigid_fit_k<K> and route2_modal_k<K>; 0: not run")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--cases", vfb.only_cases,
                              "run only these cases: drop_2cm, drop_5cm, drop_10cm, spin_roll, "
                              "wall_throw, tilted_5cm, probe_push, and impact (the impact "
                              "study, which a full run includes)")
      ->delimiter(',')
      ->check(CLI::IsMember({"drop_2cm", "drop_5cm", "drop_10cm", "spin_roll", "wall_throw",
                             "tilted_5cm", "probe_push", "impact"}));
    validate_free->add_option("--impact-speeds", vfb.impact_speeds,
                              "the impact study's speeds (m/s): the upright cat 1 mm above the "
                              "floor moving onto it, gravity off, 0.3 s (impact.csv)")
      ->capture_default_str()
      ->delimiter(',')
      ->check(CLI::Range(1e-4, 10.0));
    validate_free->add_option("--vdof-subdivisions", vfb.vdof_subdivisions,
                              "the virtual-DOF model's dome: 10 * 4^S + 2 orientations; -1: no "
                              "virtual-DOF method")
      ->capture_default_str()
      ->check(CLI::Range(-1, 4));
    validate_free->add_option("--vdof-length", vfb.vdof_length,
                              "samples per virtual-DOF response (T; the step is the scene's)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    validate_free->add_flag("--truth-check", vfb.truth_check,
                            "also run the FEM at half its step (tau / 2M) and compare it with "
                            "the FEM at tau / M by the same measures (truth.csv): how well the "
                            "truth itself is determined; triples the FEM's time");
    validate_free->add_flag("--small-strain,!--no-small-strain", vfb.small_strain,
                            "also run the FEM with a linear law (--linear-law) and report linear "
                            "elasticity's own error (it against the truth) and the method's (the "
                            "runtime against it) apart (linearization.csv); on by default")
      ->capture_default_str();
    validate_free->add_option_function<std::string>(
        "--linear-law",
        [&vfb](const std::string &law) { vfb.body_frame = law == "linear_body_frame"; },
        "that linear FEM's law: linear_body_frame (the default: the small-strain law in the "
        "body's best-fit frame, run fem_linear_body_frame) or linear (the plain small-strain "
        "law, not objective: a spin swells its body instead of turning it; run fem_small_strain, "
        "not for spin_roll)")
      ->check(CLI::IsMember({"linear_body_frame", "linear"}));
    validate_free->add_flag("--centrifugal", vfb.centrifugal,
                            "the modal routes take the spin's centrifugal force into the "
                            "deformation (the model's /modes/centrifugal_load); free flight "
                            "then runs with it as well");
    validate_free->add_flag("--deformed-inertia", vfb.deformed_inertia,
                            "the modal routes' rigid body takes the deformed body's inertia "
                            "(to first order in the deformation; the spin slows as the body "
                            "stretches); with --centrifugal, spin and stretch exchange energy "
                            "and create none; free flight then runs with it as well");
    validate_free->add_flag("--reuse-models", vfb.reuse_models,
                            "take a virtual-DOF model already in --model-dir instead of "
                            "precomputing it (it must be of the same scene and material)");

    // validate-converged
    irdm::validation::ConvergedValidationOptions vc;
    auto *validate_converged = app.add_subcommand(
      "validate-converged", "the probe scenes on the coarse cat and on a converged discretization: "
                            "method error and discretization error; reports/converged");
    validate_converged->footer(
      "Gives each probe of the named scenes a contact radius (--radius), then runs every scene "
      "on its own discretization (coarse) and on --converged-mesh at --converged-degree, each "
      "through the linear FEM and through IRDM from a model of that discretization (coarse: "
      "every mode, exact; converged: the lowest --modes modes plus residual modes, sparse "
      "route). Reports the method error (IRDM against the same FEM) and the discretization "
      "error (each FEM and model against the converged FEM) apart, with each discretization's "
      "driving-point stiffness against --extrapolated-stiffness. Writes DIR/converged/ "
      "(converged.csv, series.csv, report.md). scripts/converged.sh makes the converged mesh "
      "and reads the extrapolated stiffness from reports/convergence/. Units SI.");
    validate_converged->add_option("--scenes", vc.scenes_dir, "scene folder")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    validate_converged->add_option("--scene", vc.scenes, "scene names (repeatable or comma-separated)")
      ->delimiter(',')
      ->capture_default_str();
    validate_converged->add_option("--converged-mesh", vc.converged_mesh,
                                   "gmsh mesh of the converged discretization (for example "
                                   "cat_lc3.4mm.msh from meshes/generate.sh --study)")
      ->required()
      ->check(CLI::ExistingFile);
    validate_converged->add_option("--converged-degree", vc.converged_degree, "FE degree on it")
      ->capture_default_str()
      ->check(CLI::Range(1u, 2u));
    validate_converged->add_option("--radius", vc.probe_radius, "probes' contact radius (m)")
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 1.0));
    validate_converged->add_option("--extrapolated-stiffness", vc.extrapolated_stiffness,
                                   "mesh-converged driving-point stiffness of the first probe "
                                   "of --extrapolated-scene (N/m; 0: not stated)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e12));
    validate_converged->add_option("--extrapolated-scene", vc.extrapolated_scene,
                                   "the scene whose first probe --extrapolated-stiffness belongs "
                                   "to (compared with the scenes whose first probe starts at "
                                   "the same point along the same direction)")
      ->capture_default_str();
    validate_converged->add_option("--modes", vc.modes, "lowest modes of the converged model")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    validate_converged->add_option("--out", vc.report_dir, "report folder")->capture_default_str();
    validate_converged->add_option("--models", vc.model_dir,
                                   "folder for the working models (removed after use)")
      ->capture_default_str();

    // play
    irdm::play::PlayOptions po;
    auto *play = app.add_subcommand("play", "the two asynchronous loops in real time from a recorded device trajectory");
    play->footer("Runs a force thread (contact solve and force history) and a deformation thread (full surface update at --display-hz) "
      "in real time, sharing the body's state through a lock-free triple buffer (seed 001 "
      "section 4.2). The device (a point probe on one model vertex) moves that vertex by its own "
      "motion since it crossed the rest surface, while it is behind it. --force-modes K: the "
      "lowest K modes carry the force history, the rest respond quasi-statically (faster "
      "step; play.md states the force error against every mode). One model step per force tick: "
      "--rate-hz other than 1 / time step plays the trajectory faster or slower than real "
      "time. Writes DIR/forces.csv, histogram.csv, play.md (latency and jitter percentiles, "
      "missed deadlines, force error against the exact model) and surface/surface.pvd (VTU "
      "frames for ParaView). Exit 3 if more than 0.1 % of deadlines were missed. Example "
      "trajectories: examples/trajectories/.");
    play->add_option("model", po.model, "impulse-response model (HDF5, with its modes)")
      ->required()
      ->check(CLI::ExistingFile);
    play->add_option("--trajectory", po.trajectory, "device CSV: time_s,x_m,y_m,z_m (model frame, m)")
      ->required()
      ->check(CLI::ExistingFile);
    play->add_option("--rate-hz", po.rate_hz, "force loop rate (default: 1 / the model's time step)")
      ->check(CLI::Range(1.0, 100000.0));
    play->add_option("--display-hz", po.display_hz, "deformation loop rate")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
    play->add_option("--surface-modes", po.surface_modes, "modes of the surface update")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000000u));
    play->add_option("--force-modes", po.force_modes,
                     "modes in the force loop's history (default: all, the exact model; fewer: "
                     "faster, the rest quasi-static)")
      ->check(CLI::Range(1u, 1000000u));
    play->add_option("--vertex", po.vertex, "probed model vertex (default: the input vertex nearest the first sample)")
      ->check(CLI::Range(0L, 100000000L));
    play->add_option("--frames", po.max_frames, "VTU frames written, at most")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    play->add_option("--coupling-stiffness", po.coupling_stiffness,
                     "virtual coupling spring between device and vertex, N/m (with "
                     "--coupling-damping; both 0: the rigid probe)")
      ->check(CLI::Range(0.0, 1e12));
    play->add_option("--coupling-damping", po.coupling_damping,
                     "virtual coupling damper, N s/m")
      ->check(CLI::Range(0.0, 1e12));
    play->add_option("--out", po.out_dir, "output folder")->capture_default_str();
    play->add_flag("!--no-check", po.check, "skip the offline replay with the exact model");
    play->add_flag("!--no-pin", po.pin, "do not pin the threads to CPUs");
    play->add_option("--spin-us", po.spin_us,
                     "the force thread wakes this early and spins to each tick, us (default: "
                     "90 % of the period; 0: sleep to the tick)")
      ->check(CLI::Range(0.0, 1e6));
    play->add_option("--warm-us", po.warm_us,
                     "the deformation thread wakes this long before each frame and reads the "
                     "surface shapes into its cache until the frame (once, then a spin, with "
                     "--warm-once), us (0: it sleeps to the frame and the update streams the "
                     "shapes from memory)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
    play->add_flag("!--no-warm-step", po.warm_step,
                   "the force thread does not read the step's data into its cache at the start "
                   "of its spin (ModalInteraction::warm_step)");
    play->add_flag("!--warm-once", po.keep_warm,
                   "each warm-up runs once at the start of its spin (default: it repeats until "
                   "the tick, so that what a long interruption evicted is read back)");
    play->add_flag("!--no-baseline", po.baseline,
                   "skip the baseline (the same force loop with no work, run first for as long: "
                   "the machine's own stalls)");
    play->add_flag("--quiet", po.quiet, "no progress");

    try
      {
        app.parse(argc, argv);
      }
    catch (const CLI::ParseError &e)
      {
        // Help and version are not errors; everything else is a usage error (exit 2).
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
      }

    // Only the precomputes deal work to MPI ranks; any other command would run N times and
    // race on its outputs.
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (size > 1 && !precompute->parsed() && !precompute_vdof->parsed())
      {
        if (mpi_rank() == 0)
          std::fprintf(stderr, "irdm: error: '%s' does not run in parallel; run it without "
                               "mpirun (only precompute and precompute-vdof use MPI ranks)\n",
                       app.get_subcommands().front()->get_name().c_str());
        return 2;
      }

    if (simulate->parsed())
      return run_simulate(sim);
    if (stat->parsed())
      return run_static(static_scene);
    if (modes->parsed())
      return run_modes(modes_scene, modes_count);
    if (stiffness->parsed())
      return run_probe_stiffness(stiffness_scene, stiffness_time);
    if (verify->parsed())
      {
        irdm::check_output_folder("--out", vf.report_dir);
        return irdm::validation::run_fem_verification(vf, std::cout) ? 0 : 3;
      }
    if (precompute->parsed())
      return run_precompute(pre);
    if (precompute_vdof->parsed())
      return run_precompute_vdof(pv);
    if (compress->parsed())
      return run_compress(ca);
    if (compare->parsed())
      return run_compare_models(cmp_reference, cmp_model);
    if (validate->parsed())
      {
        irdm::check_output_folder("--out", va.report_dir);
        irdm::check_output_folder("--models", va.model_dir);
        va.full_model  = !no_full_model;
        va.plot_script = IRDM_SOURCE_DIR "/validation/plot_point_validation.py";
        return irdm::validation::run_point_validation(va, std::cout) ? 0 : 3;
      }
    if (play->parsed())
      return irdm::play::run_play(po, std::cout);
    if (validate_planes->parsed())
      {
        irdm::check_output_folder("--out", vp.report_dir);
        vp.plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_planes.py";
        irdm::validation::run_plane_validation(vp, std::cout);
        return 0;
      }
    if (validate_converged->parsed())
      {
        irdm::check_output_folder("--out", vc.report_dir);
        irdm::check_output_folder("--models", vc.model_dir);
        irdm::validation::run_converged_validation(vc, std::cout);
        return 0;
      }
    if (validate_free->parsed())
      {
        irdm::check_output_folder("--out", vfb.report_dir);
        vfb.plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_free.py";
        irdm::validation::run_free_body_validation(vfb, std::cout);
        return 0;
      }
    return 2; // not reached: CLI11 requires one subcommand
  }
} // namespace

namespace
{
  // All our files are closed by now (RAII). After a failed HDF5 close, HDF5's own cleanup at
  // MPI_Finalize would crash on that file (irdm::h5::a_close_failed()): end here instead.
  int
  finish(const int status)
  {
    if (irdm::h5::a_close_failed())
      {
        std::fflush(stdout);
        std::fflush(stderr);
        std::_Exit(status);
      }
    return status;
  }

  int
  run_reporting_errors(int argc, char **argv)
  {
    try
      {
        return run(argc, argv);
      }
    catch (const irdm::InputError &e)
      {
        std::fprintf(stderr, "irdm: error: %s\n", e.what());
        abort_other_ranks();
        return 2;
      }
    catch (const irdm::IoError &e)
      {
        std::fprintf(stderr, "irdm: error: %s\n", e.what());
        abort_other_ranks();
        return 4;
      }
    catch (const std::exception &e)
      {
        std::fprintf(stderr, "irdm: internal error: %s\n", e.what());
        abort_other_ranks();
        return 1;
      }
  }
} // namespace

int
main(int argc, char **argv)
{
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  return finish(run_reporting_errors(argc, argv));
}
