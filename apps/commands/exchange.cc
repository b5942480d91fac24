// irdm export / irdm import: impulse responses out of and into the project in the exchange
// layout (docs/model-format.md, "Responses made elsewhere").
#include "../command.h"

#include <irdm/response_exchange.h>
#include <irdm_common/files.h>

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
} // namespace irdm::cli
