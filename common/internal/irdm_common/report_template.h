#pragma once
// Reports are Markdown templates (validation/templates/, apps/templates/) filled with a
// run's figures and tables, so that the prose lives in Markdown and the C++ gives only values
// (numbers through irdm::fmt, irdm_common/format.h).
#include <map>
#include <string>

namespace irdm
{
  using TemplateValues = std::map<std::string, std::string>;

  /// Fills `text`: {{key}} becomes values.at(key); {{#key}}...{{/key}} is kept when the value is
  /// neither empty nor "0", {{^key}}...{{/key}} when it is. A key without a value, a section
  /// left open or a value the template never uses is an error (std::logic_error): a template and
  /// its writer change together.
  std::string
  fill_template(const std::string &text, const TemplateValues &values);

  /// A template of the source tree, by its path from the tree's root
  /// ("validation/templates/planes.md").
  std::string
  read_template(const std::string &path);

} // namespace irdm
