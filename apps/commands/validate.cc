// irdm validate: IRDM against the FEM on the validation scenes.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/point_validation.h>

#include <iostream>
#include <memory>

namespace irdm::cli
{
  Command
  add_validate(CLI::App &app)
  {
    struct Args
    {
      irdm::validation::PointValidationOptions options;
      bool                                     no_full_model = false;
    };
    auto a = std::make_shared<Args>();
    auto *validate = app.add_subcommand("validate", "IRDM against the FEM on validation/scenes; writes reports/");
    validate->footer("Runs every scene of --scenes through the reference FEM (ground truth) and the IRDM "
      "runtime with a model precomputed for the scene, and writes reports/<scene>/report.md "
      "with CSV and charts, and a summary reports/validation.md: (a) exactness of the "
      "untruncated model (double and float), (b) error against the response length T, (c) "
      "both against the FEM at tau/10, (d) time per step of each, measured in the same run, "
      "(e) compression (docs/compression.md). With the full model it also writes the seed's "
      "Table 1 for the cat. Exit status 3 if an untruncated double model differs from the FEM "
      "by more than 1e-9.");
    validate->add_option("--scenes", a->options.scenes_dir, "scene folder")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    validate->add_option("--out", a->options.report_dir, "report folder")->capture_default_str();
    validate->add_option("--models", a->options.model_dir,
                         "where models are written while they are used (a file already there "
                         "is never overwritten)")
      ->capture_default_str();
    validate->add_option("--scene", a->options.only, "run only this scene (repeatable)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    validate->add_flag("--no-full-model", a->no_full_model,
                       "skip the full cat model (T = 500, 4.8 GB): its precompute timing, the "
                       "seed's Table 1 and the full-model runtimes (about 5 min)");
    validate->add_option("--full-model-stride", a->options.full_model_stride,
                         "full model inputs: every k-th free surface vertex plus the first "
                         "scene's touched region (compression is per input, so a sample gives "
                         "its ratios at a k-th of the memory and time; 1: every vertex)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000u));
    validate->add_option("--length", a->options.length,
                         "samples per response of every scene's model (default: the scene's "
                         "model.length); never fewer than the scene's steps, so no run truncates")
      ->check(CLI::Range(1u, 100000u));
    return {validate, [a] {
               irdm::check_output_folder("--out", a->options.report_dir);
               irdm::check_output_folder("--models", a->options.model_dir);
               a->options.full_model  = !a->no_full_model;
               a->options.plot_script = IRDM_SOURCE_DIR "/validation/plot_point_validation.py";
               return irdm::validation::run_point_validation(a->options, std::cout) ? 0 : 3;
             }};
  }
} // namespace irdm::cli
