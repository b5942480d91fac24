#include <irdm/response_exchange.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "frame.h"

namespace irdm
{
  namespace
  {
    constexpr const char *exchange_format = "irdm-responses";

    std::vector<double>
    flat(const std::vector<std::array<double, 3>> &xyz)
    {
      std::vector<double> out;
      for (const auto &p : xyz)
        out.insert(out.end(), p.begin(), p.end());
      return out;
    }
  } // namespace

  void
  export_responses(const std::string &model_path, const std::string &out_path)
  {
    const ImpulseResponseModel m = load_model(model_path);
    if (m.free_body)
      throw InputError("export: '" + model_path + "' is a free body, whose responses need its mass "
                       "properties and rigid-body removal, which the exchange layout (version 1, "
                       "a grounded body's responses) does not carry");
    const h5::Reader           source(model_path);
    h5::Writer                 f(out_path);
    f.attribute("/", "format", std::string(exchange_format));
    f.attribute("/", "format_version", 1LL);
    f.attribute("/", "time_step_s", m.time_step);
    f.attribute("/", "convention", std::string("force_sample"));
    f.attribute("/", "units", std::string("SI: m, N, s; responses in m/N"));
    f.attribute("/", "source",
                std::string("irdm ") + IRDM_VERSION + " model '" + model_path + "'" +
                  (source.has_attribute("/", "route") ? ": " + source.string_attribute("/", "route")
                                                      : std::string()));
    f.create_group("/inputs");
    const hsize_t nvi = m.n_inputs / 3, nvo = m.n_outputs / 3;
    std::vector<double> in_xyz;
    for (const unsigned v : m.input_output_index)
      in_xyz.insert(in_xyz.end(), m.output_coordinates[v].begin(), m.output_coordinates[v].end());
    f.write("/inputs/coordinates", {nvi, 3}, in_xyz.data());
    const std::vector<long long> io(m.input_output_index.begin(), m.input_output_index.end());
    f.write("/inputs/output_index", {nvi}, io.data());
    f.create_group("/outputs");
    const auto out_xyz = flat(m.output_coordinates);
    f.write("/outputs/coordinates", {nvo, 3}, out_xyz.data());
    f.write("/outputs/node_tags", {nvo}, m.output_node_tags.data());
    if (!m.triangles.empty())
      {
        f.create_group("/surface");
        std::vector<long long> tri;
        for (const auto &t : m.triangles)
          tri.insert(tri.end(), t.begin(), t.end());
        f.write("/surface/triangles", {m.triangles.size(), 3}, tri.data());
        const std::vector<long long> ts(m.triangle_surface.begin(), m.triangle_surface.end());
        f.write("/surface/triangle_surface", {ts.size()}, ts.data());
        std::string names;
        for (const auto &n : m.surface_names)
          names += (names.empty() ? "" : ",") + n;
        f.attribute("/surface", "surface_names", names);
      }
    if (m.double_storage)
      f.write("/responses", {m.n_inputs, m.length, m.n_outputs}, m.h_double.data());
    else
      f.write("/responses", {m.n_inputs, m.length, m.n_outputs}, m.h_float.data());
    f.commit();
  }

  namespace
  {
    /// An exchange file's content as read (HDF5 or CSV), before the checks every form shares.
    struct ExchangeData
    {
      double                 tau = 0;
      std::string            convention, source;
      std::vector<double>    out_xyz, in_xyz; // (n, 3), m
      std::vector<long long> output_index;    // empty: match by coordinates
      std::vector<long long> output_tags;     // the source mesh's node tags; empty: 1, 2, ...
      std::vector<long long> triangles;       // (n_tri, 3)
      std::vector<long long> triangle_surface; // index into surface_names; empty: "imported"
      std::string            surface_names;    // comma-separated
      unsigned long long     length = 0;      // T
      std::vector<double>    H;               // [input DoF][sample][output DoF]
    };

    ExchangeData
    read_exchange_hdf5(const std::string &in_path)
    {
      const h5::Reader r(in_path);
      const auto       fail = [&](const std::string &what) -> void {
        throw InputError("responses '" + in_path + "': " + what);
      };
      if (!r.has_attribute("/", "format") || r.string_attribute("/", "format") != exchange_format)
        fail("not an exchange file (attribute 'format' is missing or not \"irdm-responses\")");
      if (r.double_attribute("/", "format_version") != 1)
        fail("format version not supported (this build reads 1)");
      ExchangeData d;
      d.tau        = r.double_attribute("/", "time_step_s");
      d.convention = r.string_attribute("/", "convention");
      d.source     = r.has_attribute("/", "source") ? r.string_attribute("/", "source") : "not stated";
      const auto shape_of = [&](const std::string &name, const size_t rank) {
        if (!r.exists(name))
          fail("missing dataset '" + name + "'");
        const auto s = r.shape(name);
        if (s.size() != rank)
          fail("'" + name + "' must have " + std::to_string(rank) + " dimensions");
        return s;
      };
      const auto so = shape_of("/outputs/coordinates", 2), si = shape_of("/inputs/coordinates", 2);
      if (so[1] != 3 || si[1] != 3 || so[0] < 1 || si[0] < 1 || si[0] > so[0] ||
          so[0] > 100000000 / 3)
        fail("coordinates must be (n, 3), 1 to 33 million outputs, no more inputs than outputs");
      d.out_xyz = r.read_double("/outputs/coordinates", {so[0], 3});
      d.in_xyz  = r.read_double("/inputs/coordinates", {si[0], 3});
      if (r.exists("/inputs/output_index"))
        d.output_index = r.read_int("/inputs/output_index", {si[0]});
      if (r.exists("/outputs/node_tags"))
        d.output_tags = r.read_int("/outputs/node_tags", {so[0]});
      if (r.exists("/surface/triangles"))
        {
          const auto st = shape_of("/surface/triangles", 2);
          if (st[1] != 3)
            fail("surface/triangles must be (n, 3)");
          d.triangles = r.read_int("/surface/triangles", st);
          if (r.exists("/surface/triangle_surface"))
            {
              if (!r.has_attribute("/surface", "surface_names"))
                fail("surface/triangle_surface needs the attribute surface_names on /surface");
              d.triangle_surface = r.read_int("/surface/triangle_surface", {st[0]});
              d.surface_names    = r.string_attribute("/surface", "surface_names");
            }
        }
      const auto sh = shape_of("/responses", 3);
      if (sh[0] != 3 * si[0] || sh[2] != 3 * so[0] || sh[1] < 1 || sh[1] > 10000000)
        fail("responses must be (3 x inputs, T, 3 x outputs)");
      check_memory_estimate("importing '" + in_path + "'", 8.0 * sh[0] * sh[1] * sh[2], false);
      d.length = sh[1];
      d.H      = r.read_double("/responses", sh);
      return d;
    }

    /// One CSV file of the exchange folder, read line by line with its position for errors.
    class CsvFile
    {
    public:
      CsvFile(const std::string &dir, const std::string &name, const bool required = true)
        : path_((std::filesystem::path(dir) / name).string()), in_(path_)
      {
        if (!in_ && required)
          throw InputError("responses '" + dir + "': missing file '" + name + "'");
      }
      bool
      present() const
      {
        return static_cast<bool>(in_);
      }
      /// The next line's comma-separated fields; false at the end.
      bool
      next(std::vector<std::string> &fields)
      {
        std::string line;
        if (!std::getline(in_, line))
          return false;
        ++line_;
        if (!line.empty() && line.back() == '\r')
          line.pop_back();
        fields.clear();
        std::stringstream ss(line);
        for (std::string f; std::getline(ss, f, ',');)
          fields.push_back(f);
        if (!line.empty() && line.back() == ',')
          fields.emplace_back();
        return true;
      }
      [[noreturn]] void
      fail(const std::string &what) const
      {
        throw InputError("responses '" + path_ + "', line " + std::to_string(line_) + ": " + what);
      }
      double
      number(const std::string &field) const
      {
        const char *b   = field.c_str();
        char       *end = nullptr;
        errno           = 0;
        const double x  = std::strtod(b, &end);
        while (end && (*end == ' ' || *end == '\t'))
          ++end;
        if (field.empty() || end == b || *end != '\0' || errno == ERANGE || !std::isfinite(x))
          fail("'" + field + "' is not a finite number");
        return x;
      }
      long long
      integer(const std::string &field, const long long lo, const long long hi) const
      {
        const double x = number(field);
        if (x != std::floor(x) || x < lo || x > hi)
          fail("'" + field + "' is not an integer from " + std::to_string(lo) + " to " + std::to_string(hi));
        return static_cast<long long>(x);
      }
      /// The header line, which must be exactly `header`.
      void
      expect_header(const std::vector<std::string> &header)
      {
        std::vector<std::string> f;
        if (!next(f) || f != header)
          {
            std::string h;
            for (const auto &x : header)
              h += (h.empty() ? "" : ",") + x;
            fail("the header must be '" + h + "'");
          }
      }

    private:
      std::string   path_;
      std::ifstream in_;
      unsigned long line_ = 0;
    };

    /// Rows of n numbers (x, y, z; a, b, c) after the header, with an optional extra column.
    void
    read_rows(CsvFile &f, const size_t n, std::vector<double> &values, std::vector<long long> *extra)
    {
      std::vector<std::string> fields;
      while (f.next(fields))
        {
          if (fields.size() == 1 && fields[0].empty())
            continue; // a blank line
          if (fields.size() != n + (extra ? 1 : 0))
            f.fail("expected " + std::to_string(n + (extra ? 1 : 0)) + " fields, found " +
                   std::to_string(fields.size()));
          for (size_t i = 0; i < n; ++i)
            values.push_back(f.number(fields[i]));
          if (extra)
            extra->push_back(f.integer(fields[n], 0, 100000000));
        }
    }

    ExchangeData
    read_exchange_csv(const std::string &dir)
    {
      ExchangeData d;
      {
        CsvFile                            meta(dir, "meta.csv");
        std::map<std::string, std::string> kv;
        std::vector<std::string>           f;
        meta.expect_header({"key", "value"});
        while (meta.next(f))
          if (!(f.size() == 1 && f[0].empty()))
            {
              if (f.size() < 2)
                meta.fail("expected key,value");
              std::string value = f[1];
              for (size_t i = 2; i < f.size(); ++i)
                value += "," + f[i]; // the value is the rest of the line
              if (!kv.emplace(f[0], value).second)
                meta.fail("key '" + f[0] + "' given twice");
            }
        const auto need = [&](const std::string &key) {
          if (!kv.count(key))
            throw InputError("responses '" + dir + "': meta.csv has no '" + key + "'");
          return kv.at(key);
        };
        if (need("format") != exchange_format)
          throw InputError("responses '" + dir + "': meta.csv's format is not irdm-responses");
        if (need("format_version") != "1")
          throw InputError("responses '" + dir + "': format version not supported (this build reads 1)");
        d.tau        = meta.number(need("time_step_s"));
        d.convention = need("convention");
        d.source     = kv.count("source") ? kv.at("source") : "not stated";
      }
      CsvFile outputs(dir, "outputs.csv"), inputs(dir, "inputs.csv"), triangles(dir, "triangles.csv", false);
      outputs.expect_header({"x_m", "y_m", "z_m"});
      read_rows(outputs, 3, d.out_xyz, nullptr);
      {
        std::vector<std::string> header;
        if (!inputs.next(header))
          inputs.fail("empty");
        const bool indexed = header.size() == 4;
        if (header != std::vector<std::string>{"x_m", "y_m", "z_m"} &&
            header != std::vector<std::string>{"x_m", "y_m", "z_m", "output_index"})
          inputs.fail("the header must be 'x_m,y_m,z_m' or 'x_m,y_m,z_m,output_index'");
        read_rows(inputs, 3, d.in_xyz, indexed ? &d.output_index : nullptr);
      }
      if (triangles.present())
        {
          std::vector<double> t;
          triangles.expect_header({"a", "b", "c"});
          read_rows(triangles, 3, t, nullptr);
          for (const double v : t)
            if (v != std::floor(v) || v < 0 || v > 1e8)
              throw InputError("responses '" + dir + "': triangles.csv holds a vertex that is not a "
                               "non-negative integer");
          d.triangles.assign(t.begin(), t.end());
        }
      const size_t nvo = d.out_xyz.size() / 3, nvi = d.in_xyz.size() / 3;
      if (nvo < 1 || nvi < 1 || nvi > nvo || nvo > 100000000 / 3)
        throw InputError("responses '" + dir + "': outputs.csv and inputs.csv must hold 1 to 33 "
                         "million outputs and no more inputs than outputs");
      // responses.csv: input_dof,sample,u_0..u_{3 n_out - 1}; each (input DoF, sample) once.
      CsvFile                  responses(dir, "responses.csv");
      std::vector<std::string> header{"input_dof", "sample"};
      for (size_t j = 0; j < 3 * nvo; ++j)
        header.push_back("u_" + std::to_string(j));
      responses.expect_header(header);
      std::vector<std::vector<double>> rows; // [input DoF * T + sample], filled in any order
      std::vector<std::pair<long long, long long>> at;
      std::vector<std::string> f;
      while (responses.next(f))
        {
          if (f.size() == 1 && f[0].empty())
            continue;
          if (f.size() != header.size())
            responses.fail("expected " + std::to_string(header.size()) + " fields, found " +
                           std::to_string(f.size()));
          const long long k = responses.integer(f[0], 0, static_cast<long long>(3 * nvi) - 1);
          const long long s = responses.integer(f[1], 0, 10000000 - 1);
          std::vector<double> u(3 * nvo);
          for (size_t j = 0; j < 3 * nvo; ++j)
            u[j] = responses.number(f[2 + j]);
          at.emplace_back(k, s);
          rows.push_back(std::move(u));
          d.length = std::max<unsigned long long>(d.length, s + 1);
        }
      if (rows.size() != 3 * nvi * d.length)
        throw InputError("responses '" + dir + "': responses.csv must hold every input DoF at "
                         "every sample 0 .. T - 1 once (" + std::to_string(rows.size()) +
                         " rows for " + std::to_string(3 * nvi) + " input DoFs and T = " +
                         std::to_string(d.length) + ")");
      d.H.assign(rows.size() * 3 * nvo, NAN);
      std::vector<char> seen(rows.size(), 0);
      for (size_t i = 0; i < rows.size(); ++i)
        {
          const size_t row = static_cast<size_t>(at[i].first) * d.length + static_cast<size_t>(at[i].second);
          if (seen[row]++)
            throw InputError("responses '" + dir + "': responses.csv gives input DoF " +
                             std::to_string(at[i].first) + " at sample " +
                             std::to_string(at[i].second) + " twice");
          std::copy(rows[i].begin(), rows[i].end(), d.H.begin() + static_cast<std::ptrdiff_t>(row * 3 * nvo));
        }
      return d;
    }

    /// The checks every form shares, then the impulse-response model file.
    ImportSummary
    write_imported_model(ExchangeData &d, const std::string &in_path, const std::string &out_path)
    {
      const auto fail = [&](const std::string &what) -> void {
        throw InputError("responses '" + in_path + "': " + what);
      };
      ImportSummary out;
      const double  tau = d.tau;
      if (!(tau > 0 && std::isfinite(tau)))
        fail("time_step_s must be a positive number of seconds");
      if (d.convention == "unit_impulse")
        out.scale = tau; // per unit impulse (m per N s): times the step gives m per force sample
      else if (d.convention != "force_sample")
        fail("convention must be \"force_sample\" or \"unit_impulse\", not \"" + d.convention + "\"");
      out.source = d.source;
      const size_t nvo = d.out_xyz.size() / 3, nvi = d.in_xyz.size() / 3;
      const auto &out_xyz = d.out_xyz, &in_xyz = d.in_xyz;
      for (const auto *v : {&out_xyz, &in_xyz})
        for (const double x : *v)
          if (!std::isfinite(x))
            fail("coordinates contain NaN or Inf");
      // Each input is an output vertex: by the index given, else the output at its coordinates.
      std::vector<long long> io(nvi, -1);
      if (!d.output_index.empty())
        io = d.output_index;
      else
        {
          out.outputs_matched_by_coordinates = true;
          double size = 0;
          for (const double x : out_xyz)
            size = std::max(size, std::abs(x));
          for (size_t k = 0; k < nvi; ++k)
            for (size_t v = 0; v < nvo && io[k] < 0; ++v)
              if (std::abs(out_xyz[3 * v] - in_xyz[3 * k]) <= 1e-9 * size &&
                  std::abs(out_xyz[3 * v + 1] - in_xyz[3 * k + 1]) <= 1e-9 * size &&
                  std::abs(out_xyz[3 * v + 2] - in_xyz[3 * k + 2]) <= 1e-9 * size)
                io[k] = static_cast<long long>(v);
        }
      std::vector<char> taken(nvo, 0);
      for (size_t k = 0; k < nvi; ++k)
        {
          if (io[k] < 0 || io[k] >= static_cast<long long>(nvo))
            fail("input " + std::to_string(k) + " is no output vertex (its output index, or no "
                 "output at its coordinates)");
          if (taken[io[k]]++)
            fail("two inputs are the same output vertex " + std::to_string(io[k]));
          for (int a = 0; a < 3; ++a)
            if (in_xyz[3 * k + a] != out_xyz[3 * io[k] + a])
              fail("input " + std::to_string(k) + " is not at its output vertex's coordinates");
        }
      if (!d.output_tags.empty())
        {
          std::vector<long long> sorted = d.output_tags;
          std::sort(sorted.begin(), sorted.end());
          if (sorted.front() < 1 || std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
            fail("the outputs' node tags must be positive and distinct");
        }
      if (!d.triangle_surface.empty())
        {
          // Counted as the model loader splits them (a trailing empty name would be lost).
          if (d.surface_names.empty() || d.surface_names.back() == ',')
            fail("surface_names must list at least one name and not end with a comma ('" +
                 d.surface_names + "')");
          long long          n_names = 0;
          std::istringstream names(d.surface_names);
          for (std::string name; std::getline(names, name, ',');)
            ++n_names;
          for (const long long t : d.triangle_surface)
            if (t < 0 || t >= n_names)
              fail("surface/triangle_surface refers to a name that surface_names does not list");
        }
      for (const long long v : d.triangles)
        if (v < 0 || v >= static_cast<long long>(nvo))
          fail("the surface triangles refer to a vertex that is not an output");
      for (double &x : d.H)
        {
          if (!std::isfinite(x))
            fail("responses contain NaN or Inf");
          x *= out.scale;
        }
      const std::string &convention = d.convention;
      const std::vector<long long> &tri = d.triangles;
      const std::vector<double> &H = d.H;
      const hsize_t sh[3] = {3 * nvi, d.length, 3 * nvo};
      h5::Writer f(out_path);
      f.attribute("/", "format", std::string("irdm-impulse-response"));
      f.attribute("/", "format_version", 2LL);
      f.attribute("/", "body", std::string("fixed"));
      f.attribute("/", "irdm_version", std::string(IRDM_VERSION));
      f.attribute("/", "time_step_s", tau);
      f.attribute("/", "length", static_cast<long long>(sh[1]));
      f.attribute("/", "storage", std::string("double"));
      f.attribute("/", "units", std::string("SI; H in m/N"));
      f.attribute("/", "convention",
                  std::string("u[n] = sum_s H[s] f[n-s], f held during step n (impulse = f * "
                              "time_step); imported as ") + convention +
                    (convention == "unit_impulse" ? " (multiplied by time_step_s)" : ""));
      f.attribute("/", "route", "imported from '" + in_path + "' (irdm import): " + out.source);
      f.attribute("/", "integrator", std::string("unknown (imported)"));
      f.attribute("/", "mesh_hash", std::string("unknown (imported)"));
      f.attribute("/", "mesh_file", std::string("unknown (imported)"));
      f.create_group("/outputs");
      std::vector<long long> out_tags(nvo), in_tags(nvi);
      // The source mesh's node tags where given, else the output vertex number from 1.
      for (hsize_t v = 0; v < nvo; ++v)
        out_tags[v] = d.output_tags.empty() ? static_cast<long long>(v) + 1 : d.output_tags[v];
      for (hsize_t k = 0; k < nvi; ++k)
        in_tags[k] = out_tags[io[k]];
      f.write("/outputs/node_tags", {nvo}, out_tags.data());
      f.write("/outputs/coordinates", {nvo, 3}, out_xyz.data());
      f.create_group("/inputs");
      f.write("/inputs/node_tags", {nvi}, in_tags.data());
      f.write("/inputs/coordinates", {nvi, 3}, in_xyz.data());
      f.write("/inputs/output_index", {nvi}, io.data());
      f.create_group("/surface");
      const hsize_t           n_tri = tri.size() / 3;
      const std::vector<long long> surface =
        d.triangle_surface.empty() ? std::vector<long long>(n_tri, 0) : d.triangle_surface;
      f.write("/surface/triangles", {n_tri, 3}, tri.data());
      f.write("/surface/triangle_surface", {n_tri}, surface.data());
      f.attribute("/surface", "surface_names",
                  d.triangle_surface.empty() ? std::string("imported") : d.surface_names);
      f.create_group("/impulse_response");
      f.write("/impulse_response/H", {sh[0], sh[1], sh[2]}, H.data());
      f.create_group("/progress");
      const long long done = 1;
      f.write("/progress/chunk_done", {1}, &done);
      f.commit();

      out.n_inputs    = static_cast<unsigned>(3 * nvi);
      out.n_outputs   = static_cast<unsigned>(3 * nvo);
      out.length      = static_cast<unsigned>(sh[1]);
      out.n_triangles = static_cast<unsigned>(n_tri);
      return out;
    }
  } // namespace

  namespace
  {
    /// A text file written through stdio with every return checked, then synced.
    class CheckedText
    {
    public:
      explicit CheckedText(const std::string &path)
        : path_(path), f_(std::fopen(path.c_str(), "wb"))
      {
        if (!f_)
          throw IoError("cannot create '" + path + "'");
      }
      ~CheckedText()
      {
        if (f_)
          std::fclose(f_);
      }
      CheckedText(const CheckedText &) = delete;
      CheckedText &
      operator=(const CheckedText &) = delete;
      void
      text(const std::string &s)
      {
        ok_ = ok_ && std::fwrite(s.data(), 1, s.size(), f_) == s.size();
      }
      /// A number that reads back to the same double (17 significant digits).
      void
      number(const double x, const char sep)
      {
        ok_ = ok_ && std::fprintf(f_, "%.17g%c", x, sep) > 0;
      }
      void
      close()
      {
        const bool flushed = std::fflush(f_) == 0;
        const bool closed  = std::fclose(f_) == 0;
        f_                 = nullptr;
        if (!ok_ || !flushed || !closed)
          throw IoError("cannot write '" + path_ + "'");
        fsync_file(path_);
      }

    private:
      std::string path_;
      std::FILE  *f_ = nullptr;
      bool        ok_ = true;
    };
  } // namespace

  void
  export_responses_csv(const std::string &model_path, const std::string &out_dir)
  {
    namespace fs               = std::filesystem;
    const ImpulseResponseModel m = load_model(model_path);
    if (m.free_body)
      throw InputError("export: '" + model_path + "' is a free body, which the exchange layout "
                       "(version 1, a grounded body's responses) does not carry");
    if (fs::exists(out_dir))
      throw InputError("export: '" + out_dir + "' exists; the CSV layout is a new folder");
    // About 24 characters a number, H's dominating.
    check_disk_estimate("exporting '" + model_path + "' as CSV", out_dir,
                        24.0 * m.n_inputs * m.length * m.n_outputs, false);
    const std::string part = out_dir + ".part";
    fs::remove_all(part); // an earlier run's unfinished folder
    fs::create_directories(part);
    try
      {
        const auto file = [&](const char *name) { return (fs::path(part) / name).string(); };
        const h5::Reader source(model_path);
        {
          CheckedText meta(file("meta.csv"));
          meta.text("key,value\nformat," + std::string(exchange_format) + "\nformat_version,1\n");
          meta.text("time_step_s,");
          meta.number(m.time_step, '\n');
          meta.text("convention,force_sample\nunits,SI: m, N, s; responses in m/N\n");
          meta.text("source,irdm " + std::string(IRDM_VERSION) + " model '" + model_path + "'" +
                    (source.has_attribute("/", "route") ? ": " + source.string_attribute("/", "route")
                                                        : std::string()) + "\n");
          meta.close();
        }
        {
          CheckedText out(file("outputs.csv"));
          out.text("x_m,y_m,z_m\n");
          for (const auto &x : m.output_coordinates)
            out.number(x[0], ','), out.number(x[1], ','), out.number(x[2], '\n');
          out.close();
          CheckedText in(file("inputs.csv"));
          in.text("x_m,y_m,z_m,output_index\n");
          for (const unsigned v : m.input_output_index)
            {
              const auto &x = m.output_coordinates[v];
              in.number(x[0], ','), in.number(x[1], ','), in.number(x[2], ',');
              in.text(std::to_string(v) + "\n");
            }
          in.close();
        }
        if (!m.triangles.empty())
          {
            CheckedText t(file("triangles.csv"));
            t.text("a,b,c\n");
            for (const auto &tri : m.triangles)
              t.text(std::to_string(tri[0]) + "," + std::to_string(tri[1]) + "," +
                     std::to_string(tri[2]) + "\n");
            t.close();
          }
        CheckedText r(file("responses.csv"));
        r.text("input_dof,sample");
        for (unsigned j = 0; j < m.n_outputs; ++j)
          r.text(",u_" + std::to_string(j));
        r.text("\n");
        for (unsigned k = 0; k < m.n_inputs; ++k)
          for (unsigned t = 0; t < m.length; ++t)
            {
              r.text(std::to_string(k) + "," + std::to_string(t) + ",");
              for (unsigned j = 0; j < m.n_outputs; ++j)
                r.number(m.h(k, t, j), j + 1 < m.n_outputs ? ',' : '\n');
            }
        r.close();
        commit_part_file(part, out_dir);
      }
    catch (...)
      {
        std::error_code ec;
        fs::remove_all(part, ec);
        throw;
      }
  }

  ImportSummary
  import_responses(const std::string &in_path, const std::string &out_path)
  {
    ExchangeData d = std::filesystem::is_directory(in_path) ? read_exchange_csv(in_path)
                                                            : read_exchange_hdf5(in_path);
    return write_imported_model(d, in_path, out_path);
  }
} // namespace irdm
