// irdm export / irdm import: impulse responses out of and into the project in the exchange
// layout (docs/model-format.md, "Responses made elsewhere"); irdm calculix: a model made by
// CalculiX through that layout (docs/calculix.md).
#include "../command.h"

#include <irdm/response_exchange.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <reference_fem/calculix.h>
#include <reference_fem/scene.h>

#include <filesystem>

#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    struct ExchangeArgs
    {
      std::string in, out;
      bool        csv = false;
    };

    struct CalculixArgs
    {
      std::string scene, out, responses, work, ccx = "ccx";
      unsigned    jobs = 2, length = 0;
      bool        keep_work = false, quiet = false;
    };
  } // namespace

  Command
  add_export(CLI::App &app)
  {
    auto  a   = std::make_shared<ExchangeArgs>();
    auto *cmd = app.add_subcommand("export", "write a model's impulse responses in the exchange layout");
    cmd->footer("Writes the impulse responses H of a model file (from 'irdm precompute' or 'irdm "
                "import') as an 'irdm-responses' file (HDF5; docs/model-format.md): the time "
                "step, the convention (force_sample: H[s] is the displacement s steps after a "
                "force of 1 N held for one step), input and output coordinates (m), the surface "
                "triangles, H (m/N). With --csv the same as a folder of CSV files. 'irdm import' "
                "reads either back into the same H.");
    cmd->add_option("model", a->in, "model file with H")->required()->check(CLI::ExistingFile);
    cmd->add_option("--out", a->out, "exchange file to write (with --csv: a new folder)")->required();
    cmd->add_flag("--csv", a->csv,
                  "the CSV layout: a folder of meta.csv, outputs.csv, inputs.csv, triangles.csv, "
                  "responses.csv (one row per input DoF and sample; for small models: the cat's "
                  "every-vertex H would take tens of GB as text)");
    return {cmd, [a] {
              irdm::check_output_file("--out", a->out, {a->in});
              if (a->csv)
                irdm::export_responses_csv(a->in, a->out);
              else
                irdm::export_responses(a->in, a->out);
              std::printf("exported %s -> %s\n", a->in.c_str(), a->out.c_str());
              return 0;
            }};
  }

  Command
  add_import(CLI::App &app)
  {
    auto  a   = std::make_shared<ExchangeArgs>();
    auto *cmd = app.add_subcommand("import", "make a model file from impulse responses made elsewhere");
    cmd->footer("Reads an 'irdm-responses' exchange file (HDF5, or a folder of CSV files; "
                "docs/model-format.md: responses "
                "per force sample or per unit impulse, input and output coordinates, surface "
                "triangles where known) and writes an impulse-response model (format version 2, "
                "H in double, no modes) that every command taking a model with H accepts: the "
                "direct runtime, 'irdm compress' (representatives, --method era), "
                "'irdm compare-models'. Inputs without an output index are matched to the output "
                "vertex at their coordinates.");
    cmd->add_option("responses", a->in, "exchange file, or a folder in the CSV layout")
      ->required()
      ->check(CLI::ExistingPath);
    cmd->add_option("--out", a->out, "model file to write")->required();
    return {cmd, [a] {
              irdm::check_output_file("--out", a->out, {a->in});
              const auto s = irdm::import_responses(a->in, a->out);
              std::printf("imported %s -> %s: %u inputs x %u steps x %u outputs (DoFs), %u "
                          "triangles%s%s; source: %s\n",
                          a->in.c_str(), a->out.c_str(), s.n_inputs, s.length, s.n_outputs,
                          s.n_triangles,
                          s.outputs_matched_by_coordinates ? ", inputs matched by coordinates" : "",
                          s.scale != 1 ? ", per unit impulse times the step" : "",
                          s.source.c_str());
              return 0;
            }};
  }

  Command
  add_calculix(CLI::App &app)
  {
    auto  a   = std::make_shared<CalculixArgs>();
    auto *cmd = app.add_subcommand("calculix", "make a model with CalculiX (a second FEM) through the exchange layout");
    cmd->footer("For each input DoF of the scene's model region (as 'irdm precompute' picks it), "
                "writes a CalculiX deck (the mesh as C3D4 elements, the fixed surfaces clamped, "
                "the material, the Rayleigh damping, one force sample of 1 N held for one step) "
                "and runs ccx with *DYNAMIC, DIRECT at the scene's step: HHT-alpha, which is the "
                "scene's integrator exactly for newmark and for generalized-alpha at rho_inf "
                "0.5 (others refused). The output vertices' displacements at every step become "
                "the responses (exchange layout, force_sample convention), imported as a model "
                "every command accepts. CalculiX's C3D4 mass is integrated at the centroid; the "
                "scene's \"mass_matrix\": \"one_point\" gives our FEM the same (docs/calculix.md). "
                "Debian package: calculix-ccx.");
    cmd->add_option("scene", a->scene, "scene file (P1, linear, fixed body)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--out", a->out, "model file to write")->required();
    cmd->add_option("--responses", a->responses,
                    "also keep the exchange file CalculiX's responses were gathered in (HDF5)");
    cmd->add_option("--work", a->work,
                    "a new folder for the decks and CalculiX's output (default: <out>.calculix, "
                    "removed when done)");
    cmd->add_flag("--keep-work", a->keep_work, "keep the work folder");
    cmd->add_option("--ccx", a->ccx, "the CalculiX executable")->capture_default_str();
    cmd->add_option("--jobs", a->jobs, "CalculiX runs at once, one thread each")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
    cmd->add_option("--length", a->length, "samples per response (default: the scene's model length)");
    cmd->add_flag("--quiet", a->quiet, "no progress on stderr");
    return {cmd, [a] {
              irdm::check_output_file("--out", a->out, {a->scene});
              const std::string responses =
                a->responses.empty() ? a->out + ".responses.h5" : a->responses;
              if (!a->responses.empty())
                irdm::check_output_file("--responses", responses, {a->scene, a->out});
              else if (std::filesystem::exists(responses))
                throw irdm::InputError("calculix: '" + responses + "' exists (a scratch file of "
                                       "an earlier run?); remove it or give --responses");
              const auto scene = irdm::fem::read_scene(a->scene);
              irdm::fem::CalculixOptions o;
              o.responses = responses;
              o.work_dir  = a->work.empty() ? a->out + ".calculix" : a->work;
              o.ccx       = a->ccx;
              o.jobs      = a->jobs;
              o.keep_work = a->keep_work;
              if (a->length > 0)
                o.length = a->length;
              const auto rep = irdm::fem::calculix_responses(scene, o, stderr_log(a->quiet));
              struct Scratch
              {
                std::string path;
                ~Scratch()
                {
                  std::error_code ec;
                  if (!path.empty())
                    std::filesystem::remove(path, ec);
                }
              } scratch{a->responses.empty() ? responses : std::string()};
              const auto s = irdm::import_responses(responses, a->out);
              std::printf("calculix %s -> %s: %u inputs x %u steps x %u outputs (DoFs), %u "
                          "triangles; %s, %.1f s of CalculiX runs\n",
                          a->scene.c_str(), a->out.c_str(), s.n_inputs, s.length, s.n_outputs,
                          s.n_triangles, rep.ccx_version.c_str(), rep.seconds);
              return 0;
            }};
  }
} // namespace irdm::cli
