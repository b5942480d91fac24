#include <irdm/response_exchange.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <cmath>

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
    if (!m.triangles.empty())
      {
        f.create_group("/surface");
        std::vector<long long> tri;
        for (const auto &t : m.triangles)
          tri.insert(tri.end(), t.begin(), t.end());
        f.write("/surface/triangles", {m.triangles.size(), 3}, tri.data());
      }
    if (m.double_storage)
      f.write("/responses", {m.n_inputs, m.length, m.n_outputs}, m.h_double.data());
    else
      f.write("/responses", {m.n_inputs, m.length, m.n_outputs}, m.h_float.data());
    f.commit();
  }

  ImportSummary
  import_responses(const std::string &in_path, const std::string &out_path)
  {
    const h5::Reader r(in_path);
    const auto       fail = [&](const std::string &what) -> void {
      throw InputError("responses '" + in_path + "': " + what);
    };
    if (!r.has_attribute("/", "format") || r.string_attribute("/", "format") != exchange_format)
      fail("not an exchange file (attribute 'format' is missing or not \"irdm-responses\")");
    if (r.double_attribute("/", "format_version") != 1)
      fail("format version not supported (this build reads 1)");
    ImportSummary out;
    const double  tau = r.double_attribute("/", "time_step_s");
    if (!(tau > 0 && std::isfinite(tau)))
      fail("time_step_s must be a positive number of seconds");
    const std::string convention = r.string_attribute("/", "convention");
    if (convention == "unit_impulse")
      out.scale = tau; // per unit impulse (m per N s): times the step gives m per force sample
    else if (convention != "force_sample")
      fail("convention must be \"force_sample\" or \"unit_impulse\", not \"" + convention + "\"");
    out.source = r.has_attribute("/", "source") ? r.string_attribute("/", "source") : "not stated";

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
    const hsize_t nvo = so[0], nvi = si[0];
    const auto    out_xyz = r.read_double("/outputs/coordinates", {nvo, 3});
    const auto    in_xyz  = r.read_double("/inputs/coordinates", {nvi, 3});
    for (const auto *v : {&out_xyz, &in_xyz})
      for (const double x : *v)
        if (!std::isfinite(x))
          fail("coordinates contain NaN or Inf");
    // Each input is an output vertex: by the index given, else the output at its coordinates.
    std::vector<long long> io(nvi, -1);
    if (r.exists("/inputs/output_index"))
      io = r.read_int("/inputs/output_index", {nvi});
    else
      {
        out.outputs_matched_by_coordinates = true;
        double size = 0;
        for (const double x : out_xyz)
          size = std::max(size, std::abs(x));
        for (hsize_t k = 0; k < nvi; ++k)
          for (hsize_t v = 0; v < nvo && io[k] < 0; ++v)
            if (std::abs(out_xyz[3 * v] - in_xyz[3 * k]) <= 1e-9 * size &&
                std::abs(out_xyz[3 * v + 1] - in_xyz[3 * k + 1]) <= 1e-9 * size &&
                std::abs(out_xyz[3 * v + 2] - in_xyz[3 * k + 2]) <= 1e-9 * size)
              io[k] = static_cast<long long>(v);
      }
    std::vector<char> taken(nvo, 0);
    for (hsize_t k = 0; k < nvi; ++k)
      {
        if (io[k] < 0 || io[k] >= static_cast<long long>(nvo))
          fail("input " + std::to_string(k) + " is no output vertex (inputs/output_index, or no "
               "output at its coordinates)");
        if (taken[io[k]]++)
          fail("two inputs are the same output vertex " + std::to_string(io[k]));
        for (int a = 0; a < 3; ++a)
          if (in_xyz[3 * k + a] != out_xyz[3 * io[k] + a])
            fail("input " + std::to_string(k) + " is not at its output vertex's coordinates");
      }
    std::vector<long long> tri;
    if (r.exists("/surface/triangles"))
      {
        const auto st = shape_of("/surface/triangles", 2);
        if (st[1] != 3)
          fail("surface/triangles must be (n, 3)");
        tri = r.read_int("/surface/triangles", st);
        for (const long long v : tri)
          if (v < 0 || v >= static_cast<long long>(nvo))
            fail("surface/triangles refers to a vertex that is not an output");
      }
    const auto sh = shape_of("/responses", 3);
    if (sh[0] != 3 * nvi || sh[2] != 3 * nvo || sh[1] < 1 || sh[1] > 10000000)
      fail("responses must be (3 x inputs, T, 3 x outputs)");
    check_memory_estimate("importing '" + in_path + "'", 8.0 * sh[0] * sh[1] * sh[2], false);
    std::vector<double> H = r.read_double("/responses", sh);
    for (double &x : H)
      {
        if (!std::isfinite(x))
          fail("responses contain NaN or Inf");
        x *= out.scale;
      }

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
    for (hsize_t v = 0; v < nvo; ++v)
      out_tags[v] = static_cast<long long>(v) + 1; // tags: output vertex number from 1
    for (hsize_t k = 0; k < nvi; ++k)
      in_tags[k] = io[k] + 1;
    f.write("/outputs/node_tags", {nvo}, out_tags.data());
    f.write("/outputs/coordinates", {nvo, 3}, out_xyz.data());
    f.create_group("/inputs");
    f.write("/inputs/node_tags", {nvi}, in_tags.data());
    f.write("/inputs/coordinates", {nvi, 3}, in_xyz.data());
    f.write("/inputs/output_index", {nvi}, io.data());
    f.create_group("/surface");
    const hsize_t           n_tri = tri.size() / 3;
    const std::vector<long long> surface(n_tri, 0);
    f.write("/surface/triangles", {n_tri, 3}, tri.data());
    f.write("/surface/triangle_surface", {n_tri}, surface.data());
    f.attribute("/surface", "surface_names", std::string("imported"));
    f.create_group("/impulse_response");
    f.write("/impulse_response/H", {sh[0], sh[1], sh[2]}, H.data());
    f.create_group("/progress");
    const long long done = 1;
    f.write("/progress/chunk_done", {1}, &done);
    f.commit();

    out.n_inputs    = 3 * nvi;
    out.n_outputs   = 3 * nvo;
    out.length      = static_cast<unsigned>(sh[1]);
    out.n_triangles = static_cast<unsigned>(n_tri);
    return out;
  }
} // namespace irdm
