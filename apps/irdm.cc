// irdm: one command-line program with subcommands. Exit status: 0 ok, 2 bad input or usage,
// 1 internal error.
#include <irdm/representative_model.h>
#include <irdm_common/error.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/virtual_dof.h>
#include <reference_fem/scene.h>
#include <validation/fem_verification.h>
#include <validation/plane_validation.h>
#include <validation/point_validation.h>

#include <deal.II/base/mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace
{
  const char *top_help = R"(irdm: impulse response deformation model (IRDM) validation harness

Usage: irdm <command> [options]

Commands (reference FEM):
  simulate <scene.json>   run a scene with the reference FEM and write its outputs
  static <scene.json>     static equilibrium under the scene's loads at t = 0
  modes <scene.json>      lowest natural frequencies of the fixed body
  verify-fem              FEM verification suite against theory; writes a report

Commands (IRDM):
  precompute <scene.json> impulse-response model of the scene's body (HDF5); mpirun-able
  precompute-vdof <scene.json>  virtual-DOF model (plane contact, seed 001); mpirun-able
  compress <model.h5>     compress a model by representative waveforms (seed 000 sec. 3)
  validate                IRDM against the FEM on validation/scenes; writes reports/
  validate-planes         virtual-DOF plane contact against the nonlinear FEM; reports/planes

Run 'irdm <command> --help' for the options of a command. Units are SI throughout.
Scene files: docs/scene-format.md. Result files: docs/fem-output.md.
)";

  struct Args
  {
    std::vector<std::string>           positional;
    std::map<std::string, std::string> options; // --key value, or --flag -> ""
  };

  // Parses "--key value" / "--flag"; rejects options not in the allowed lists.
  Args
  parse(const int argc, char **argv, const int first,
        const std::vector<std::string> &with_value, const std::vector<std::string> &flags)
  {
    Args a;
    for (int i = first; i < argc; ++i)
      {
        const std::string s = argv[i];
        if (s.rfind("--", 0) == 0)
          {
            const auto is = [&](const std::vector<std::string> &l) {
              for (const auto &x : l)
                if (x == s)
                  return true;
              return false;
            };
            if (is(with_value))
              {
                if (i + 1 >= argc)
                  throw irdm::InputError("option " + s + " needs a value");
                a.options[s] = argv[++i];
              }
            else if (is(flags))
              a.options[s] = "";
            else
              throw irdm::InputError("unknown option '" + s + "' (see --help)");
          }
        else
          a.positional.push_back(s);
      }
    return a;
  }

  unsigned
  positive_integer(const std::string &option, const std::string &value)
  {
    char *end = nullptr;
    const long v = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || v < 1 || v > 100000)
      throw irdm::InputError("option " + option + " needs a whole number >= 1, got '" +
                             value + "'");
    return static_cast<unsigned>(v);
  }

  void
  print_progress(const double fraction)
  {
    std::fprintf(stderr, "\r  %3.0f %%", 100 * fraction);
    if (fraction >= 1)
      std::fprintf(stderr, "\n");
  }

  int
  cmd_simulate(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm simulate <scene.json> [--quiet]

Runs the scene with the reference FEM (P1/P2 tetrahedra, implicit Newmark or
generalized-alpha) from its initial state to its duration, and writes the outputs the scene
asks for (HDF5, CSV, VTU) into its output directory. "kinematics": "linear" (default) is
small-strain elasticity; "nonlinear" is Total Lagrangian neo-Hookean elasticity with Newton
at each step, rigid planes (penalty contact) and an initial velocity.
  --quiet   no progress on stderr
)";
    const Args a = parse(argc, argv, 2, {}, {"--help", "--quiet"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("simulate takes one scene file (see --help)");
    const auto scene = irdm::fem::read_scene(a.positional[0]);
    const auto progress = a.options.count("--quiet") ? nullptr : print_progress;
    irdm::fem::RunResult result;
    if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
      {
        irdm::fem::NonlinearElasticity fem(scene);
        std::fprintf(stderr, "%s: nonlinear (neo-Hookean), %u steps of %g s\n",
                     scene.name.c_str(), scene.n_steps(), scene.time_step);
        result = fem.run(progress);
        fem.write_outputs(result);
      }
    else
      {
        irdm::fem::ElasticDynamics fem(scene);
        std::fprintf(stderr, "%s: %u cells, %u DoFs (P%u), %u steps of %g s\n",
                     scene.name.c_str(), fem.n_cells(), fem.n_dofs(), scene.fe_degree,
                     scene.n_steps(), scene.time_step);
        result = fem.run(progress);
        fem.write_outputs(result);
      }
    std::printf("setup %.3f s, factorization %.3f s, %u steps in %.3f s (%.3g ms/step)\n",
                result.setup_seconds, result.factorization_seconds, result.n_steps,
                result.stepping_seconds, 1e3 * result.stepping_seconds / result.n_steps);
    if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
      std::printf("Newton: %u iterations, %u tangent factorizations\n",
                  result.newton_iterations, result.tangent_factorizations);
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
        std::printf("plane %s: peak force %.6g N, deepest penetration %.4g m (penalty %.3g Pa/m)\n",
                    name.c_str(), peak, deepest, result.plane_penalty.at(name));
      }
    if (!scene.outputs.directory.empty())
      std::printf("outputs in %s\n", scene.outputs.directory.c_str());
    return 0;
  }

  int
  cmd_static(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm static <scene.json>

Solves K u = f for the scene's loads (and gravity) at t = 0 with its fixed surfaces and
prescribed displacements, prints the reactions and observed displacements, and writes the
outputs like 'simulate' (one sample).
)";
    const Args a = parse(argc, argv, 2, {}, {"--help"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("static takes one scene file (see --help)");
    const auto scene = irdm::fem::read_scene(a.positional[0]);
    irdm::fem::ElasticDynamics fem(scene);
    const auto r = fem.solve_static(0.0);
    std::printf("volume %.9g m^3, %u DoFs\n", fem.volume(), fem.n_dofs());
    for (const auto &[name, s] : r.fixed_reaction)
      std::printf("reaction on %s: (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                  s[0][2]);
    for (const auto &[name, s] : r.vertex_displacement)
      std::printf("vertex %s: u = (%.9g, %.9g, %.9g) m\n", name.c_str(), s[0][0], s[0][1],
                  s[0][2]);
    for (const auto &[name, s] : r.probe_force)
      std::printf("probe %s: F = (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                  s[0][2]);
    fem.write_outputs(r);
    return 0;
  }

  int
  cmd_modes(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm modes <scene.json> [--count N]

Lowest natural frequencies (Hz) of the scene's body with its fixed surfaces, undamped.
  --count N   number of frequencies (default 6)
)";
    const Args a = parse(argc, argv, 2, {"--count"}, {"--help"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("modes takes one scene file (see --help)");
    const unsigned n =
      a.options.count("--count") ? positive_integer("--count", a.options.at("--count")) : 6;
    const auto scene = irdm::fem::read_scene(a.positional[0]);
    irdm::fem::ElasticDynamics fem(scene);
    const auto f = fem.natural_frequencies(n);
    for (unsigned i = 0; i < f.size(); ++i)
      std::printf("mode %u: %.9g Hz\n", i + 1, f[i]);
    return 0;
  }

  double
  real_in(const std::string &option, const std::string &value, const double lo, const double hi)
  {
    char        *end = nullptr;
    const double v   = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || !(v >= lo && v <= hi))
      throw irdm::InputError("option " + option + " needs a number in [" + std::to_string(lo) +
                             ", " + std::to_string(hi) + "], got '" + value + "'");
    return v;
  }

  /// --storage float|double, if given.
  std::optional<bool>
  storage_option(const Args &a)
  {
    if (!a.options.count("--storage"))
      return std::nullopt;
    const std::string st = a.options.at("--storage");
    if (st != "float" && st != "double")
      throw irdm::InputError("--storage must be float or double, got '" + st + "'");
    return st == "double";
  }

  int
  cmd_precompute(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm precompute <scene.json> --out MODEL.h5 [options]
       mpirun -np N irdm precompute <scene.json> --out MODEL.h5 [options]

Computes the impulse-response model H[s] of the scene's body (mesh, material, damping, fixed
surfaces, integrator and time step tau = the scene's step) by exact modal decoupling of the
reference FEM's own integrator, and writes it to an HDF5 file (layout: docs/model-format.md).
Inputs, outputs, length T and storage come from the scene's "model" section (default: every
free surface vertex DoF in and out, T = 500, float). Under mpirun the inputs are split
across ranks; the file is the same as a serial run's. An interrupted run leaves MODEL.h5.part
and the next run with the same spec resumes it.
  --out FILE        model file to write (required)
  --length T        samples per response (overrides the scene)
  --storage S       float or double (overrides the scene)
  --chunk K         inputs per chunk (default: about 64 MB of responses)
  --restart         ignore a partial file and start over
  --quiet           no progress on stderr
)";
    const Args a = parse(argc, argv, 2, {"--out", "--length", "--storage", "--chunk"},
                         {"--help", "--restart", "--quiet"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("precompute takes one scene file (see --help)");
    if (!a.options.count("--out"))
      throw irdm::InputError("precompute needs --out MODEL.h5");
    const auto scene = irdm::fem::read_scene(a.positional[0]);
    irdm::fem::PrecomputeOptions o;
    o.output = a.options.at("--out");
    if (a.options.count("--length"))
      o.length = positive_integer("--length", a.options.at("--length"));
    if (a.options.count("--chunk"))
      o.inputs_per_chunk = positive_integer("--chunk", a.options.at("--chunk"));
    o.double_storage = storage_option(a);
    o.restart = a.options.count("--restart") > 0;
    if (!a.options.count("--quiet"))
      o.log = [](const std::string &s) { std::fprintf(stderr, "  %s\n", s.c_str()); };
    const auto r = irdm::fem::precompute_impulse_responses(scene, o);
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank == 0)
      std::printf("model %s: %u outputs x %u inputs x %u samples, %.1f MB (%s), %d rank(s)\n"
                  "time: total %.2f s = FEM %.2f + modes %.2f + responses %.2f + write %.2f "
                  "(+ other)\nenergy left after T: mean %.3g, max %.3g; static compliance beyond T: "
                  "mean %.3g, max %.3g\n",
                  o.output.c_str(), r.n_outputs, r.n_inputs, r.length, r.bytes / 1e6,
                  r.double_storage ? "double" : "float", r.ranks, r.seconds_total,
                  r.seconds_fem, r.seconds_eigen, r.seconds_responses, r.seconds_write,
                  r.energy_left_mean, r.energy_left_max, r.static_left_mean, r.static_left_max);
    return 0;
  }

  int
  cmd_precompute_vdof(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm precompute-vdof <scene.json> --out VDOF.h5 [options]
       mpirun -np N irdm precompute-vdof <scene.json> --out VDOF.h5 [options]

Virtual degrees of freedom (seed 001): for each plane orientation (the vertices of a geodesic
dome), hits the scene's grounded body once with a rigid frictionless wall in the nonlinear
FEM (neo-Hookean, penalty contact) and records the responses of the surface and of every
virtual DOF to that impulse, per newton of wall force (docs/model-format.md). Uses the
scene's mesh, material, damping, integrator, step, fixed surfaces and model length T; loads,
probes and gravity are left out. Under mpirun the orientations are dealt to the ranks; rank 0
writes. The time of every orientation is printed and stored.
  --out FILE          model file to write (required)
  --subdivisions S    icosahedron subdivisions: 10 * 4^S + 2 orientations (default 2: 162)
  --depth D           m, the wall's penetration into the undeformed body during its one step
                      of contact (default 0.001)
  --band B            m, vertices within B of a plane at first contact define its virtual
                      DOF's displacement (default 0.001, the seed's 1 mm)
  --length T          samples per response (overrides the scene)
  --storage S         float or double (overrides the scene)
  --quiet             no progress on stderr
)";
    const Args a = parse(argc, argv, 2,
                         {"--out", "--subdivisions", "--depth", "--band", "--length", "--storage"},
                         {"--help", "--quiet"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("precompute-vdof takes one scene file (see --help)");
    if (!a.options.count("--out"))
      throw irdm::InputError("precompute-vdof needs --out VDOF.h5");
    const auto scene = irdm::fem::read_scene(a.positional[0]);
    irdm::fem::VirtualDofOptions o;
    o.output = a.options.at("--out");
    if (a.options.count("--subdivisions"))
      o.subdivisions = static_cast<unsigned>(real_in("--subdivisions", a.options.at("--subdivisions"), 0, 4));
    if (a.options.count("--depth"))
      o.impulse_depth = real_in("--depth", a.options.at("--depth"), 1e-7, 0.05);
    if (a.options.count("--band"))
      o.band = real_in("--band", a.options.at("--band"), 1e-7, 0.05);
    if (a.options.count("--length"))
      o.length = positive_integer("--length", a.options.at("--length"));
    o.double_storage = storage_option(a);
    if (!a.options.count("--quiet"))
      o.log = [](const std::string &s) { std::fprintf(stderr, "  %s\n", s.c_str()); };
    const auto r = irdm::fem::precompute_virtual_dofs(scene, o);
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank == 0)
      std::printf("virtual DOF model %s: %u orientations x %u samples, %u surface vertices, "
                  "%d rank(s)\ntime: total %.2f s; per orientation mean %.2f s, max %.2f s "
                  "(one rank); %u Newton iterations\nimpulse forces %.4g to %.4g N\n",
                  o.output.c_str(), r.n_orientations, r.length, r.n_surface, r.ranks,
                  r.seconds_total, r.seconds_per_orientation_mean, r.seconds_per_orientation_max,
                  r.newton_iterations, r.impulse_force_min, r.impulse_force_max);
    return 0;
  }

  int
  cmd_compress(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm compress <model.h5> --out COMPRESSED.h5 [options]

Compresses an impulse-response model (from 'irdm precompute') by representative waveforms
(seed 000, section 3; docs/compression.md): every waveform H_kj is kept as a representative or
replaced by representatives of the same input, delayed (d >= 0 steps) and scaled, when their
correlation reaches theta. The output is a model the runtime runs directly (no decompression),
with the source's metadata plus theta and the statistics (docs/model-format.md).
  --out FILE         compressed model to write (required)
  --theta X          correlation threshold in (0, 1] (default 0.9)
  --blend B          representatives blended per waveform: 1 = plain substitution (the
                     seed's), 2..4 = interpolation among nearby ones (default 1)
  --max-delay D      largest delay searched, steps (default 64)
  --candidates C     nearest representatives searched per waveform (default 8)
  --threads N        worker threads (default: all cores)
  --quiet            no progress on stderr
)";
    const Args a = parse(argc, argv, 2,
                         {"--out", "--theta", "--blend", "--max-delay", "--candidates", "--threads"},
                         {"--help", "--quiet"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (a.positional.size() != 1)
      throw irdm::InputError("compress takes one model file (see --help)");
    if (!a.options.count("--out"))
      throw irdm::InputError("compress needs --out COMPRESSED.h5");
    irdm::CompressionOptions o;
    if (a.options.count("--theta"))
      o.theta = real_in("--theta", a.options.at("--theta"), 1e-6, 1);
    if (a.options.count("--blend"))
      o.blend = positive_integer("--blend", a.options.at("--blend"));
    if (a.options.count("--max-delay"))
      o.max_delay = static_cast<unsigned>(real_in("--max-delay", a.options.at("--max-delay"), 0, 65535));
    if (a.options.count("--candidates"))
      o.candidates = positive_integer("--candidates", a.options.at("--candidates"));
    if (a.options.count("--threads"))
      o.threads = positive_integer("--threads", a.options.at("--threads"));
    if (!a.options.count("--quiet"))
      o.log = [](const std::string &s) { std::fprintf(stderr, "  %s\n", s.c_str()); };
    const std::string in = a.positional[0];
    const auto        model = irdm::load_model(in);
    const auto        c     = irdm::compress(model, o);
    irdm::save_representative_model(c, in, a.options.at("--out"));
    const double waveforms = static_cast<double>(model.n_inputs) * model.n_outputs;
    std::printf("compressed %s -> %s: theta %.3g, blend %u\n"
                "waveforms %.0f: %llu representative (%.3g %%), %llu substituted; mean fit %.4f, "
                "min fit %.4f, mean delay %.2f steps, largest delay %u\n"
                "size: representatives %.2f MB + blend tables %.2f MB = %.2f MB, %.3g %% of %.1f MB "
                "(float H); time %.2f s\n",
                in.c_str(), a.options.at("--out").c_str(), c.theta, c.blend, waveforms,
                static_cast<unsigned long long>(c.n_representative()), 100 * c.n_representative() / waveforms,
                static_cast<unsigned long long>(c.n_substituted), c.mean_fit, c.min_fit,
                c.mean_delay, c.delay_span, c.representative_bytes() / 1e6,
                (c.bytes() - c.representative_bytes()) / 1e6, c.bytes() / 1e6,
                100 * c.bytes() / (4 * waveforms * model.length), 4 * waveforms * model.length / 1e6,
                c.compression_seconds);
    return 0;
  }

  int
  cmd_validate_planes(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm validate-planes [--scene FILE] [--out DIR] [--model FILE] [--subdivisions S] [--length T]

Plane contact by virtual DOFs (seed 001) against the nonlinear reference FEM on the grounded
cat: a rigid wall pressing from the side, from the top, and from two directions between the
dome's (at a dome triangle's centre) at depths 2 to 20 mm, and hitting the side at 0.05 to
0.5 m/s (2 mm deep). Precomputes the virtual-DOF model first (or reuses
--model when it was made from the same scene, S and T; run 'mpirun -np N irdm
precompute-vdof' to make it in parallel). Writes DIR/planes/planes.md, planes.csv and
planes.png, forces.csv: force and surface-displacement errors, nearest against interpolated
orientation mapping, the surface error when driven by the FEM's force (open loop), time per
step of both methods in the same run.
  --scene FILE        the body (default validation/scenes/press.json; its probes are ignored)
  --out DIR           report directory (default reports)
  --model FILE        virtual-DOF model (default out/models/cat_vdof.h5)
  --subdivisions S    dome subdivisions (default 2: 162 orientations)
  --length T          samples per response (default 300: the longest case, 0.6 s)
)";
    const Args a = parse(argc, argv, 2, {"--scene", "--out", "--model", "--subdivisions", "--length"},
                         {"--help"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (!a.positional.empty())
      throw irdm::InputError("validate-planes takes no positional arguments (see --help)");
    irdm::validation::PlaneValidationOptions o;
    if (a.options.count("--scene"))
      o.scene = a.options.at("--scene");
    if (a.options.count("--out"))
      o.report_dir = a.options.at("--out");
    if (a.options.count("--model"))
      o.model_file = a.options.at("--model");
    if (a.options.count("--subdivisions"))
      o.subdivisions = static_cast<unsigned>(real_in("--subdivisions", a.options.at("--subdivisions"), 0, 4));
    if (a.options.count("--length"))
      o.length = positive_integer("--length", a.options.at("--length"));
    o.plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_planes.py";
    irdm::validation::run_plane_validation(o, std::cout);
    return 0;
  }

  int
  cmd_validate(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm validate [--scenes DIR] [--out DIR] [--models DIR] [--scene NAME]... [--no-full-model]

Runs every scene of --scenes through the reference FEM (ground truth) and the IRDM runtime
with a model precomputed for the scene, and writes reports/<scene>/report.md with CSV and
charts, and a summary reports/validation.md: (a) exactness of the untruncated model (double
and float), (b) error against the response length T, (c) both against the FEM at tau/10,
(d) time per step of each, measured in the same run, (e) compression: representative
waveforms (plain and interpolated, theta 0.80 .. 0.999) and the modal realization run in
closed loop, with errors, time per step, memory and stability (docs/compression.md). With the
full model it also writes the seed's Table 1 for the cat. Exit status 3 if an untruncated
double model differs from the FEM by more than 1e-9.
  --scenes DIR     scene folder (default: validation/scenes)
  --out DIR        report folder (default: reports)
  --models DIR     where models are written while they are used (default: out/models)
  --scene NAME     run only this scene (repeatable)
  --no-full-model  skip the full cat model (T = 500, 4.8 GB): its precompute timing, the
                   seed's Table 1 and the full-model runtimes (about 5 min)
)";
    const Args a = parse(argc, argv, 2, {"--scenes", "--out", "--models", "--scene"},
                         {"--help", "--no-full-model"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (!a.positional.empty())
      throw irdm::InputError("validate takes no positional arguments (see --help)");
    irdm::validation::PointValidationOptions o;
    if (a.options.count("--scenes"))
      o.scenes_dir = a.options.at("--scenes");
    if (a.options.count("--out"))
      o.report_dir = a.options.at("--out");
    if (a.options.count("--models"))
      o.model_dir = a.options.at("--models");
    for (int i = 2; i + 1 < argc; ++i)
      if (std::string(argv[i]) == "--scene")
        o.only.push_back(argv[i + 1]);
    o.full_model  = a.options.count("--no-full-model") == 0;
    o.plot_script = IRDM_SOURCE_DIR "/validation/plot_point_validation.py";
    const bool exact = irdm::validation::run_point_validation(o, std::cout);
    return exact ? 0 : 3;
  }

  int
  cmd_verify_fem(const int argc, char **argv)
  {
    const char *help = R"(Usage: irdm verify-fem [--meshes DIR] [--out DIR] [--quick]

Runs the reference-FEM verification suite (cantilever frequency and convergence, static tip
deflection, energy conservation and dissipation, gravity reaction, damping, prescribed
displacement reaction; nonlinear mode: a ball's peak contact force against Hertz over impact
speed, mesh and penalty) and writes a Markdown report with CSV data under --out; about 10 min
on 2 cores (--quick: 1.5 min). Exit code 0: every check passed; 3: some check failed (the
report says which); other: an error.
  --meshes DIR  folder with the project's meshes (default: meshes)
  --out DIR     report folder (default: reports/fem-verification)
  --quick       skip the finest beam and ball meshes and most impact speeds (for a fast look;
                the report says so)
)";
    const Args a = parse(argc, argv, 2, {"--meshes", "--out"}, {"--help", "--quick"});
    if (a.options.count("--help"))
      return std::printf("%s", help), 0;
    if (!a.positional.empty())
      throw irdm::InputError("verify-fem takes no positional arguments (see --help)");
    irdm::validation::FemVerificationOptions o;
    if (a.options.count("--meshes"))
      o.mesh_dir = a.options.at("--meshes");
    if (a.options.count("--out"))
      o.report_dir = a.options.at("--out");
    o.quick = a.options.count("--quick") > 0;
    const bool all_pass = irdm::validation::run_fem_verification(o, std::cout);
    return all_pass ? 0 : 3;
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
} // namespace

int
main(int argc, char **argv)
{
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  try
    {
      if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")
        {
          std::printf("%s", top_help);
          return argc < 2 ? 2 : 0;
        }
      const std::string cmd = argv[1];
      if (cmd == "simulate")
        return cmd_simulate(argc, argv);
      if (cmd == "static")
        return cmd_static(argc, argv);
      if (cmd == "modes")
        return cmd_modes(argc, argv);
      if (cmd == "verify-fem")
        return cmd_verify_fem(argc, argv);
      if (cmd == "precompute")
        return cmd_precompute(argc, argv);
      if (cmd == "precompute-vdof")
        return cmd_precompute_vdof(argc, argv);
      if (cmd == "validate")
        return cmd_validate(argc, argv);
      if (cmd == "compress")
        return cmd_compress(argc, argv);
      if (cmd == "validate-planes")
        return cmd_validate_planes(argc, argv);
      std::fprintf(stderr, "irdm: unknown command '%s'\n\n%s", cmd.c_str(), top_help);
      return 2;
    }
  catch (const irdm::InputError &e)
    {
      std::fprintf(stderr, "irdm: error: %s\n", e.what());
      abort_other_ranks();
      return 2;
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "irdm: internal error: %s\n", e.what());
      abort_other_ranks();
      return 1;
    }
}
