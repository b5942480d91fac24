// Markdown report templates (report_template.h).
#include <irdm_common/report_template.h>

#include <irdm_common/error.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace irdm
{
  namespace
  {
    bool
    truthy(const std::string &v)
    {
      return !v.empty() && v != "0";
    }

    // Fills text[from, to) into out; returns where it stopped: `to`, or the start of the
    // closing tag {{/section}} when section is not empty.
    std::size_t
    fill(const std::string &text, std::size_t from, const std::string &section,
         const TemplateValues &values, std::set<std::string> &used, std::string *out)
    {
      while (true)
        {
          const std::size_t open = text.find("{{", from);
          if (open == std::string::npos)
            {
              if (!section.empty())
                throw std::logic_error("report template: {{#" + section + "}} is never closed");
              if (out)
                out->append(text, from, std::string::npos);
              return text.size();
            }
          if (out)
            out->append(text, from, open - from);
          const std::size_t close = text.find("}}", open);
          if (close == std::string::npos)
            throw std::logic_error("report template: '{{' without '}}'");
          const std::string tag  = text.substr(open + 2, close - open - 2);
          const char        kind = tag.empty() ? ' ' : tag[0];
          const std::string key  = (kind == '#' || kind == '^' || kind == '/') ? tag.substr(1) : tag;
          const auto        v    = values.find(key);
          if (v == values.end())
            throw std::logic_error("report template: no value for {{" + tag + "}}");
          used.insert(key);
          if (kind == '/')
            {
              if (key != section)
                throw std::logic_error("report template: {{/" + key + "}} closes no section");
              return open;
            }
          from = close + 2;
          if (kind == '#' || kind == '^')
            {
              const bool keep = (kind == '#') == truthy(v->second);
              const std::size_t end = fill(text, from, key, values, used, keep ? out : nullptr);
              from = end + key.size() + 5; // past {{/key}}
            }
          else if (out)
            out->append(v->second);
        }
    }
  } // namespace

  std::string
  fill_template(const std::string &text, const TemplateValues &values)
  {
    std::string           out;
    std::set<std::string> used;
    fill(text, 0, "", values, used, &out);
    for (const auto &[key, value] : values)
      if (!used.count(key))
        throw std::logic_error("report template: the value '" + key + "' is never used");
    return out;
  }

  std::string
  read_template(const std::string &relative)
  {
    const std::string path = std::string(IRDM_SOURCE_DIR) + "/" + relative;
    std::ifstream     in(path);
    if (!in)
      throw IoError("cannot read the report template '" + path + "'");
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
} // namespace irdm
