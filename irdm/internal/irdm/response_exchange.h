#pragma once
// Impulse responses made elsewhere (another FEM, measurements) in and out of the project
// (issue 51): the exchange layout `irdm-responses` version 1, HDF5 or a folder of CSV files, documented in
// docs/model-format.md. Import turns it into an impulse-response model file that every command
// taking a model with H accepts; export writes one of ours in it.
#include <irdm/model.h>

#include <string>

namespace irdm
{
  /// Writes the exchange file of a model with H (InputError for a file written with
  /// --modal-only). The convention written is "force_sample" (H as stored).
  void
  export_responses(const std::string &model_path, const std::string &out_path);

  /// The same in the CSV layout: a new folder out_dir (meta.csv, outputs.csv, inputs.csv,
  /// triangles.csv where the model has them, responses.csv; docs/model-format.md), every number
  /// in 17 significant digits so that it reads back to the same double. InputError when
  /// out_dir exists.
  void
  export_responses_csv(const std::string &model_path, const std::string &out_dir);

  /// What an import made, for its report.
  struct ImportSummary
  {
    unsigned    n_inputs = 0, n_outputs = 0, length = 0, n_triangles = 0;
    bool        outputs_matched_by_coordinates = false;
    double      scale = 1; // applied to the stored responses (the step for "unit_impulse")
    std::string source;
  };

  /// Reads an exchange file, or a folder in the CSV layout (every field checked; InputError
  /// naming the file, the line and the field) and writes an impulse-response model (format
  /// version 2, H in double, no modes).
  ImportSummary
  import_responses(const std::string &in_path, const std::string &out_path);
} // namespace irdm
