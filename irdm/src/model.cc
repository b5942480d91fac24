#include <irdm/model.h>
#include <irdm/rigid_body.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include "frame.h"

#include <irdm_common/files.h>

#include <algorithm>

#include <cmath>
#include <sstream>

namespace irdm
{
  ImpulseResponseModel
  ImpulseResponseModel::as_float() const
  {
    if (!double_storage)
      return *this;
    // Frame and modes copied, H converted straight into the copy: a whole copy first would
    // hold the double H twice (1.5 GB extra for the trace scene's model).
    ImpulseResponseModel m;
    static_cast<ModelFrame &>(m) = static_cast<const ModelFrame &>(*this);
    m.modes          = modes;
    m.double_storage = false;
    m.h_float.assign(h_double.begin(), h_double.end());
    return m;
  }

  void
  read_frame(const h5::Reader &r, const std::string &path, ModelFrame &m,
             const std::optional<double> expected_time_step)
  {
    const auto        fail = [&](const std::string &what) -> void {
      throw InputError("model '" + path + "': " + what);
    };
    m.time_step = r.double_attribute("/", "time_step_s");
    m.length    = static_cast<unsigned>(r.count_attribute("/", "length", 1, 10000000));
    if (!(m.time_step > 0) || !std::isfinite(m.time_step))
      fail("time_step_s must be a positive number");
    if (expected_time_step &&
        std::abs(m.time_step - *expected_time_step) > 1e-12 * *expected_time_step)
      fail("it was made with time step " + std::to_string(m.time_step) + " s but the scene uses " +
           std::to_string(*expected_time_step) + " s; the responses encode the step, so "
           "precompute a model at the scene's step");
    m.integrator      = r.string_attribute("/", "integrator");
    m.mesh_hash       = r.string_attribute("/", "mesh_hash");
    m.storage_on_disk = r.string_attribute("/", "storage");
    if (r.has_attribute("/", "body"))
      {
        const std::string body = r.string_attribute("/", "body");
        if (body != "free" && body != "fixed")
          fail("attribute 'body' must be \"free\" or \"fixed\", not \"" + body + "\"");
        m.free_body = body == "free";
      }
    if (m.free_body)
      {
        for (const char *name : {"/rigid_body/mass_kg", "/rigid_body/center_of_mass_m",
                                 "/rigid_body/inertia_kg_m2"})
          if (!r.exists(name))
            fail("a free body needs dataset '" + std::string(name) + "'");
        const auto mass    = r.read_double("/rigid_body/mass_kg", {1});
        const auto center  = r.read_double("/rigid_body/center_of_mass_m", {3});
        const auto inertia = r.read_double("/rigid_body/inertia_kg_m2", {3, 3});
        bool       finite  = std::isfinite(mass[0]) && mass[0] > 0;
        for (int i = 0; i < 3; ++i)
          {
            m.center_of_mass[i] = center[i];
            finite              = finite && std::isfinite(center[i]);
            for (int j = 0; j < 3; ++j)
              {
                m.inertia[i][j] = inertia[3 * i + j];
                finite          = finite && std::isfinite(inertia[3 * i + j]);
              }
          }
        if (!finite)
          fail("rigid_body/mass_kg must be positive, rigid_body/center_of_mass_m and "
               "rigid_body/inertia_kg_m2 finite");
        m.mass = mass[0];
        // The inertia must be one a body can have (symmetric, triangle inequality).
        RigidBodyInertia check;
        check.mass = m.mass;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            check.inertia(i, j) = m.inertia[i][j];
        try
          {
            RigidBody body(check);
          }
        catch (const InputError &e)
          {
            fail(std::string("rigid_body/inertia_kg_m2: ") + e.what());
          }
      }

    for (const char *name : {"/outputs/node_tags", "/outputs/coordinates", "/inputs/node_tags",
                             "/inputs/output_index", "/surface/triangles",
                             "/surface/triangle_surface"})
      if (!r.exists(name))
        fail("missing dataset '" + std::string(name) + "'");
    const auto n_out_v = r.shape("/outputs/node_tags");
    const auto n_in_v  = r.shape("/inputs/node_tags");
    if (n_out_v.size() != 1 || n_in_v.size() != 1)
      fail("node_tags must be one-dimensional");
    if (n_out_v[0] < 1 || n_out_v[0] > 100000000 / 3 || n_in_v[0] > n_out_v[0])
      fail("outputs/node_tags must name 1 to 33 million output vertices, inputs/node_tags no "
           "more inputs than outputs");
    m.output_node_tags = r.read_int("/outputs/node_tags", n_out_v);
    const auto xyz     = r.read_double("/outputs/coordinates", {n_out_v[0], 3});
    for (const double x : xyz)
      if (!std::isfinite(x))
        fail("outputs/coordinates contains NaN or Inf");
    for (size_t i = 0; i < n_out_v[0]; ++i)
      m.output_coordinates.push_back({xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
    m.input_node_tags = r.read_int("/inputs/node_tags", n_in_v);
    for (const auto *tags : {&m.output_node_tags, &m.input_node_tags})
      {
        std::vector<long long> sorted = *tags;
        std::sort(sorted.begin(), sorted.end());
        if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
          fail("a node tag appears twice among the " +
               std::string(tags == &m.output_node_tags ? "outputs" : "inputs"));
      }
    m.n_outputs       = 3 * n_out_v[0];
    m.n_inputs        = 3 * n_in_v[0];
    m.output_input_index.assign(n_out_v[0], -1);
    if (r.shape("/inputs/output_index") != n_in_v)
      fail("inputs/output_index must have as many entries as inputs/node_tags");
    const auto io = r.read_int("/inputs/output_index", n_in_v);
    for (size_t k = 0; k < io.size(); ++k)
      {
        if (io[k] < 0 || io[k] >= static_cast<long long>(n_out_v[0]))
          fail("inputs/output_index out of range");
        if (m.output_input_index[io[k]] >= 0)
          fail("inputs/output_index names output " + std::to_string(io[k]) + " twice");
        if (m.output_node_tags[io[k]] != m.input_node_tags[k])
          fail("inputs/output_index: input " + std::to_string(k) +
               " is not the output vertex it names (node tags differ)");
        m.input_output_index.push_back(static_cast<unsigned>(io[k]));
        m.output_input_index[io[k]] = static_cast<int>(k);
      }
    const auto ts = r.shape("/surface/triangles");
    if (ts.size() != 2 || ts[1] != 3)
      fail("surface/triangles must have shape (n, 3)");
    const auto tri = r.read_int("/surface/triangles", ts);
    const auto tsf = r.read_int("/surface/triangle_surface", {ts[0]});
    for (size_t t = 0; t < ts[0]; ++t)
      {
        std::array<unsigned, 3> v;
        for (int i = 0; i < 3; ++i)
          {
            if (tri[3 * t + i] < 0 || tri[3 * t + i] >= static_cast<long long>(n_out_v[0]))
              fail("surface/triangles refers to a vertex that is not an output");
            v[i] = static_cast<unsigned>(tri[3 * t + i]);
          }
        m.triangles.push_back(v);
        m.triangle_surface.push_back(static_cast<int>(tsf[t]));
      }
    {
      std::istringstream names(r.string_attribute("/surface", "surface_names"));
      std::string        s;
      while (std::getline(names, s, ','))
        m.surface_names.push_back(s);
    }
    for (const int t : m.triangle_surface)
      if (t < 0 || t >= static_cast<int>(m.surface_names.size()))
        fail("surface/triangle_surface refers to a surface name that is not listed");
  }

  void
  check_complete(const h5::Reader &r, const std::string &path)
  {
    if (!r.exists("/progress/chunk_done"))
      return;
    const auto shape = r.shape("/progress/chunk_done");
    if (shape.size() != 1)
      throw InputError("model '" + path + "': progress/chunk_done must be one-dimensional");
    const auto done = r.read_int("/progress/chunk_done", shape);
    const auto n    = std::count(done.begin(), done.end(), 1LL);
    if (n != static_cast<long long>(done.size()))
      throw InputError("model '" + path + "' is incomplete: " + std::to_string(n) + " of " +
                       std::to_string(done.size()) + " chunks were written; run the "
                       "precompute again to finish it");
  }

  template <class Fail>
  void
  read_impulse_response(const h5::Reader &r, const std::string &path, ImpulseResponseModel &m,
                        const Fail &fail)
  {
    if (!r.exists("/impulse_response/H"))
      fail("missing dataset '/impulse_response/H'");
    const std::vector<hsize_t> hs = {m.n_inputs, m.length, m.n_outputs};
    if (r.shape("/impulse_response/H") != hs)
      fail("impulse_response/H has the wrong shape (expected inputs x length x outputs = " +
           std::to_string(m.n_inputs) + " x " + std::to_string(m.length) + " x " +
           std::to_string(m.n_outputs) + ")");
    m.double_storage = r.is_double("/impulse_response/H");
    check_memory_estimate("loading model '" + path + "'",
                          (m.double_storage ? 8.0 : 4.0) * m.n_inputs * m.length * m.n_outputs,
                          false);
    bool finite      = true;
    if (m.double_storage)
      {
        m.h_double = r.read_double("/impulse_response/H", hs);
        for (const double x : m.h_double)
          finite = finite && std::isfinite(x);
      }
    else
      {
        m.h_float = r.read_float("/impulse_response/H", hs);
        for (const float x : m.h_float)
          finite = finite && std::isfinite(x);
      }
    if (!finite)
      fail("impulse_response/H contains NaN or Inf");
  }

  ImpulseResponseModel
  load_model(const std::string &path, const std::optional<double> expected_time_step,
             const ModelParts parts)
  {
    h5::Reader r(path);
    const auto fail = [&](const std::string &what) -> void {
      throw InputError("model '" + path + "': " + what);
    };
    if (!r.has_attribute("/", "format") ||
        r.string_attribute("/", "format") != "irdm-impulse-response")
      fail("not an IRDM impulse-response model (attribute 'format' is missing or different)");
    const double version = r.double_attribute("/", "format_version");
    // Version 2 added free bodies (attribute body, group /rigid_body); version 1 files are
    // fixed bodies and read unchanged. Version 3: the modal realization without H
    // (precompute --modal-only).
    if (version != 1 && version != 2 && version != 3)
      fail("format version " + std::to_string(version) +
           " is not supported (this build reads 1, 2 and 3)");
    check_complete(r, path);
    ImpulseResponseModel m;
    read_frame(r, path, m, expected_time_step);
    m.modal_only = version == 3;
    if (m.modal_only)
      {
        if (parts == ModelParts::impulse_response)
          fail("holds only its modal realization, not H (precomputed with --modal-only): "
               "this use needs H; precompute it again without --modal-only, or run it through "
               "the modal runtime");
        if (!r.exists("/modes/shapes") || !r.exists("/modes/step"))
          fail("format version 3 (the modal realization only) but /modes is missing");
      }
    else
      read_impulse_response(r, path, m, fail);
    if (r.exists("/modes/shapes") && r.exists("/modes/step"))
      {
        const auto shape = r.shape("/modes/shapes");
        if (shape.size() != 2 || shape[0] != m.n_outputs || shape[1] < 1 ||
            shape[1] > m.n_outputs + 100000000ull)
          fail("modes/shapes must have shape (outputs, modes) with at least one mode");
        ModalData &md   = m.modes;
        md.n_modes      = static_cast<unsigned>(shape[1]);
        md.frequency_hz = r.read_double("/modes/frequency_Hz", {shape[1]});
        md.damping_ratio = r.read_double("/modes/damping_ratio", {shape[1]});
        md.shapes       = r.read_double("/modes/shapes", shape);
        md.step         = r.read_double("/modes/step", {shape[1], 3, 5});
        if (r.exists("/modes/load_shapes"))
          md.load_shapes = r.read_double("/modes/load_shapes", shape);
        if (r.exists("/modes/centrifugal_load"))
          md.centrifugal_load = r.read_double("/modes/centrifugal_load", {shape[1], 3, 3});
        if (r.exists("/modes/inertial_coupling"))
          {
            const auto j = r.shape("/modes/inertial_coupling");
            if (j.size() != 4 || j[0] != 3 || j[1] != 3 || j[2] != j[3] || j[2] < 1 ||
                j[2] > shape[1])
              fail("modes/inertial_coupling must have shape (3, 3, r, r), 1 <= r <= modes");
            md.inertial_modes    = static_cast<unsigned>(j[2]);
            md.inertial_coupling = r.read_double("/modes/inertial_coupling", j);
          }
        for (const auto *v : {&md.frequency_hz, &md.damping_ratio, &md.shapes, &md.load_shapes,
                              &md.step, &md.centrifugal_load, &md.inertial_coupling})
          for (const double x : *v)
            if (!std::isfinite(x))
              fail("the modal realization (/modes) contains NaN or Inf");
        for (unsigned i = 0; i < md.n_modes; ++i)
          if (!(md.frequency_hz[i] >= 0) || !(md.damping_ratio[i] >= 0) ||
              (i > 0 && md.frequency_hz[i] < md.frequency_hz[i - 1]))
            fail("modes/frequency_Hz must be ascending and >= 0, damping_ratio >= 0");
      }
    return m;
  }
} // namespace irdm
