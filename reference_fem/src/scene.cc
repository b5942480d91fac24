// Scene file parsing. Every object is checked for unknown keys, so a typo is an error
// instead of a silently ignored setting.
#include <irdm_common/error.h>
#include <reference_fem/scene.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace irdm::fem
{
  using json = nlohmann::json;
  namespace fs = std::filesystem;

  namespace
  {
    // Piecewise-linear lookup: t lies at fraction w from times[k] to times[k + 1]; held
    // constant outside the samples (w = 0 at the first or last sample).
    std::pair<size_t, double>
    segment(const std::vector<double> &times, const double t)
    {
      if (t <= times.front())
        return {0, 0.0};
      if (t >= times.back())
        return {times.size() - 1, 0.0};
      const size_t k =
        static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
      return {k, (t - times[k]) / (times[k + 1] - times[k])};
    }
  } // namespace

  Vec3
  History::at(const double t) const
  {
    if (times.empty())
      return {0, 0, 0};
    const auto [k, w] = segment(times, t);
    Vec3 v;
    for (int d = 0; d < 3; ++d)
      v[d] = (1 - w) * values[k][d] + w * values[k + 1 < values.size() ? k + 1 : k][d];
    return v;
  }

  double
  ScalarHistory::at(const double t) const
  {
    if (times.empty())
      return 0;
    const auto [k, w] = segment(times, t);
    return (1 - w) * values[k] + w * values[k + 1 < values.size() ? k + 1 : k];
  }

  Vec3
  RigidPlane::normal_at(const double t) const
  {
    if (normal_path.times.empty())
      return normal;
    const Vec3   n = normal_path.at(t);
    const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return {n[0] / l, n[1] / l, n[2] / l};
  }

  History
  History::constant(const Vec3 &v)
  {
    return History{{0.0}, {v}};
  }

  unsigned
  Scene::n_steps() const
  {
    return static_cast<unsigned>(std::llround(duration / time_step));
  }

  std::array<double, 2>
  rayleigh_from_ratios(const double zeta1,
                       const double f1,
                       const double zeta2,
                       const double f2)
  {
    const double w1 = 2 * M_PI * f1, w2 = 2 * M_PI * f2;
    // [1/(2 w1)  w1/2; 1/(2 w2)  w2/2] [alpha; beta] = [zeta1; zeta2]
    const double det = w2 / (4 * w1) - w1 / (4 * w2);
    const double alpha = (zeta1 * w2 / 2 - zeta2 * w1 / 2) / det;
    const double beta  = (zeta2 / (2 * w1) - zeta1 / (2 * w2)) / det;
    return {alpha, beta};
  }

  namespace
  {
    [[noreturn]] void
    fail(const std::string &where, const std::string &what)
    {
      throw InputError("scene " + where + ": " + what);
    }

    // A JSON object with its path in the scene, for error messages.
    struct Node
    {
      const json &j;
      std::string where;

      void
      allow_only(std::initializer_list<const char *> keys) const
      {
        if (!j.is_object())
          fail(where, "must be an object");
        const std::set<std::string> allowed(keys.begin(), keys.end());
        for (const auto &item : j.items())
          if (!allowed.count(item.key()))
            {
              std::string list;
              for (const auto &k : allowed)
                list += (list.empty() ? "" : ", ") + k;
              fail(where, "unknown key '" + item.key() + "' (allowed: " + list + ")");
            }
      }
      bool
      has(const char *key) const
      {
        return j.contains(key);
      }
      Node
      at(const char *key) const
      {
        if (!j.contains(key))
          fail(where, "missing key '" + std::string(key) + "'");
        return Node{j.at(key), where + "." + key};
      }
      double
      number() const
      {
        if (!j.is_number())
          fail(where, "must be a number");
        const double v = j.get<double>();
        if (!std::isfinite(v))
          fail(where, "must be finite");
        return v;
      }
      double
      positive() const
      {
        const double v = number();
        if (!(v > 0))
          fail(where, "must be > 0 (got " + j.dump() + ")");
        return v;
      }
      long long
      integer() const
      {
        if (!j.is_number_integer())
          fail(where, "must be an integer");
        return j.get<long long>();
      }
      bool
      boolean() const
      {
        if (!j.is_boolean())
          fail(where, "must be true or false");
        return j.get<bool>();
      }
      std::string
      string() const
      {
        if (!j.is_string())
          fail(where, "must be a string");
        return j.get<std::string>();
      }
      std::vector<Node>
      array() const
      {
        if (!j.is_array())
          fail(where, "must be an array");
        std::vector<Node> out;
        for (size_t i = 0; i < j.size(); ++i)
          out.push_back(Node{j[i], where + "[" + std::to_string(i) + "]"});
        return out;
      }
      Vec3
      vec3() const
      {
        const auto a = array();
        if (a.size() != 3)
          fail(where, "must be an array of 3 numbers");
        return {a[0].number(), a[1].number(), a[2].number()};
      }
    };

    std::string
    resolve(const std::string &base_dir, const std::string &p)
    {
      if (p.empty() || fs::path(p).is_absolute())
        return p;
      return (fs::path(base_dir) / p).lexically_normal().string();
    }

    VertexSelector
    parse_vertex(const Node &n)
    {
      n.allow_only({"node_tag", "nearest_to_m"});
      VertexSelector v;
      if (n.has("node_tag") == n.has("nearest_to_m"))
        fail(n.where, "give exactly one of 'node_tag' or 'nearest_to_m'");
      if (n.has("node_tag"))
        {
          v.node_tag = n.at("node_tag").integer();
          if (v.node_tag < 1)
            fail(n.where + ".node_tag", "gmsh node tags start at 1");
        }
      else
        v.point = n.at("nearest_to_m").vec3();
      return v;
    }

    // "history": {"times_s": [...], "factors": [...]} scales a vector; or
    // {"csv": "file"} with columns time_s,x,y,z gives the vector directly.
    History
    parse_history(const Node &parent,
                  const char *vector_key,
                  const std::string &base_dir)
    {
      const bool has_vec = parent.has(vector_key);
      if (!parent.has("history"))
        {
          if (!has_vec)
            fail(parent.where, "missing key '" + std::string(vector_key) + "'");
          return History::constant(parent.at(vector_key).vec3());
        }
      const Node h = parent.at("history");
      h.allow_only({"times_s", "factors", "csv"});
      History out;
      if (h.has("csv"))
        {
          if (has_vec)
            fail(parent.where, "a csv history gives the vector itself: drop '" +
                                 std::string(vector_key) + "'");
          if (h.has("times_s") || h.has("factors"))
            fail(h.where, "give either 'csv' or 'times_s' with 'factors'");
          const std::string file = resolve(base_dir, h.at("csv").string());
          std::ifstream     in(file);
          if (!in)
            fail(h.where + ".csv", "cannot open '" + file + "'");
          std::string line;
          size_t      line_no = 0;
          while (std::getline(in, line))
            {
              ++line_no;
              if (line.empty() || line[0] == '#' || std::isalpha(line[0]))
                continue; // comments and the header line
              std::replace(line.begin(), line.end(), ',', ' ');
              std::istringstream s(line);
              double             t;
              Vec3               v;
              if (!(s >> t >> v[0] >> v[1] >> v[2]))
                fail(h.where + ".csv", file + ":" + std::to_string(line_no) +
                                         ": expected 4 numbers: time_s,x,y,z");
              out.times.push_back(t);
              out.values.push_back(v);
            }
        }
      else
        {
          if (!has_vec)
            fail(parent.where, "missing key '" + std::string(vector_key) + "'");
          const Vec3 vec     = parent.at(vector_key).vec3();
          const auto times   = h.at("times_s").array();
          const auto factors = h.at("factors").array();
          if (times.size() != factors.size())
            fail(h.where, "'times_s' and 'factors' differ in length");
          for (size_t i = 0; i < times.size(); ++i)
            {
              out.times.push_back(times[i].number());
              const double f = factors[i].number();
              out.values.push_back({f * vec[0], f * vec[1], f * vec[2]});
            }
        }
      if (out.times.empty())
        fail(h.where, "is empty");
      for (size_t i = 1; i < out.times.size(); ++i)
        if (!(out.times[i] > out.times[i - 1]))
          fail(h.where, "times must be strictly increasing");
      for (const auto &v : out.values)
        for (const double x : v)
          if (!std::isfinite(x))
            fail(h.where, "values must be finite");
      return out;
    }

    // A virtual coupling {"stiffness_N_m": k, "damping_N_s_m": b} (contact::Coupling).
    void
    parse_coupling(const Node &c, double &stiffness, double &damping)
    {
      c.allow_only({"stiffness_N_m", "damping_N_s_m"});
      if (c.has("stiffness_N_m"))
        stiffness = c.at("stiffness_N_m").number();
      if (c.has("damping_N_s_m"))
        damping = c.at("damping_N_s_m").number();
      if (!(stiffness >= 0) || !(damping >= 0) || !(stiffness > 0 || damping > 0))
        fail(c.where, "needs stiffness_N_m >= 0 and damping_N_s_m >= 0, not both zero (leave "
                      "out 'coupling' for a rigid probe or plane)");
    }

    // {"times_s": [...], <key>: [...]} with strictly increasing times.
    void
    parse_samples(const Node &h, const char *key, std::vector<double> &times,
                  std::vector<Node> &samples)
    {
      h.allow_only({"times_s", key});
      for (const auto &t : h.at("times_s").array())
        times.push_back(t.number());
      samples = h.at(key).array();
      if (times.empty())
        fail(h.where, "is empty");
      if (times.size() != samples.size())
        fail(h.where, "'times_s' and '" + std::string(key) + "' differ in length");
      for (size_t i = 1; i < times.size(); ++i)
        if (!(times[i] > times[i - 1]))
          fail(h.where, "times must be strictly increasing");
    }

    VertexRegion
    parse_region(const Node &n)
    {
      n.allow_only({"surfaces", "within"});
      VertexRegion r;
      if (n.has("surfaces"))
        for (const auto &x : n.at("surfaces").array())
          r.surfaces.push_back(x.string());
      if (n.has("within"))
        {
          const Node              w = n.at("within");
          std::vector<Node>       balls;
          if (w.j.is_array())
            balls = w.array();
          else
            balls.push_back(w);
          for (const auto &b : balls)
            {
              b.allow_only({"center_m", "radius_m"});
              r.balls.emplace_back(b.at("center_m").vec3(), b.at("radius_m").positive());
            }
        }
      return r;
    }

    // Where in the text a number overflows a double: "line L, key 'K': 1e400 ...".
    std::string
    overflowing_number(const std::string &text)
    {
      std::size_t line = 1;
      std::string last_key;
      for (std::size_t i = 0; i < text.size(); ++i)
        {
          const char c = text[i];
          if (c == '\n')
            ++line;
          else if (c == '"')
            {
              const std::size_t end = text.find('"', i + 1);
              if (end == std::string::npos)
                break;
              last_key = text.substr(i + 1, end - i - 1);
              i        = end;
            }
          else if (c == '-' || std::isdigit(static_cast<unsigned char>(c)))
            {
              std::size_t j = i;
              while (j < text.size() && std::strchr("0123456789+-.eE", text[j]))
                ++j;
              const std::string token = text.substr(i, j - i);
              if (!std::isfinite(std::strtod(token.c_str(), nullptr)))
                return "line " + std::to_string(line) + ", key '" + last_key + "': the number " +
                       token + " is too large for a double";
              i = j - 1;
            }
        }
      return "a number is too large for a double";
    }

    std::string
    parse_name(const Node &n, const std::string &fallback)
    {
      if (!n.has("name"))
        return fallback;
      const std::string s = n.at("name").string();
      if (s.empty() || s.find_first_of("/ \t\n,") != std::string::npos)
        fail(n.where + ".name", "must be non-empty, without '/', ',' or spaces");
      // Names become file names (VTU frames, HDF5 groups): keep them short and plain.
      if (s.size() > 64)
        fail(n.where + ".name", "must have at most 64 characters (it has " +
                                  std::to_string(s.size()) + ")");
      for (const char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
          fail(n.where + ".name", "may hold only letters, digits, '_', '-' and '.'");
      return s;
    }
    /// The names of loads, probes, planes and observed vertices: each used once. A nameless one
    /// is named after its kind and how many names came before it.
    struct Names
    {
      std::set<std::string> used;
      std::string
      operator()(const Node &n, const std::string &kind)
      {
        const std::string name = parse_name(n, kind + std::to_string(used.size()));
        if (!used.insert(name).second)
          fail(n.where, "name '" + name + "' is used twice");
        return name;
      }
    };

    /// The mesh and the element degree.
    void
    parse_body(const Node &top, const std::string &base_dir, Scene &s)
    {
    {
      const Node m = top.at("mesh");
      m.allow_only({"file"});
      s.mesh_file = resolve(base_dir, m.at("file").string());
      if (!fs::exists(s.mesh_file))
        fail(m.where + ".file", "mesh file '" + s.mesh_file + "' does not exist");
    }
    if (top.has("fe_degree"))
      {
        const long long p = top.at("fe_degree").integer();
        if (p != 1 && p != 2)
          fail(top.where + ".fe_degree", "must be 1 or 2 (linear or quadratic tetrahedra)");
        s.fe_degree = static_cast<unsigned>(p);
      }
    if (top.has("mass_matrix"))
      {
        const std::string m = top.at("mass_matrix").string();
        if (m != "consistent" && m != "one_point")
          fail(top.where + ".mass_matrix", "must be 'consistent' or 'one_point'");
        s.one_point_mass = m == "one_point";
      }
    }

    /// Young's modulus, Poisson's ratio, density and the law.
    void
    parse_material(const Node &top, Scene &s)
    {
    {
      const Node m = top.at("material");
      m.allow_only({"youngs_modulus_Pa", "poisson_ratio", "density_kg_m3", "law"});
      s.youngs_modulus = m.at("youngs_modulus_Pa").number();
      if (!(s.youngs_modulus > 0))
        fail(m.where + ".youngs_modulus_Pa", "must be > 0");
      s.poisson_ratio = m.at("poisson_ratio").number();
      if (!(s.poisson_ratio > -1 && s.poisson_ratio < 0.5))
        fail(m.where + ".poisson_ratio",
             "must lie in (-1, 0.5) for a stable isotropic solid (got " +
               std::to_string(s.poisson_ratio) + ")");
      s.density = m.at("density_kg_m3").positive();
      if (m.has("law"))
        {
          const std::string law = m.at("law").string();
          if (law == "linear" || law == "linear_body_frame")
            s.small_strain_law = true;
          else if (law != "neo_hookean" && law != "corotational")
            fail(m.where + ".law",
                 "must be 'neo_hookean', 'corotational', 'linear' or 'linear_body_frame'");
          s.body_frame_law   = law == "linear_body_frame";
          s.corotational_law = law == "corotational";
        }
    }
    }

    /// Rayleigh damping: coefficients, or two ratios at two frequencies.
    void
    parse_damping(const Node &top, Scene &s)
    {
    if (top.has("damping"))
      {
        const Node d = top.at("damping");
        d.allow_only({"rayleigh_alpha_1_s", "rayleigh_beta_s", "ratios", "frequencies_Hz"});
        const bool coeffs = d.has("rayleigh_alpha_1_s") || d.has("rayleigh_beta_s");
        const bool ratios = d.has("ratios") || d.has("frequencies_Hz");
        if (coeffs && ratios)
          fail(d.where, "give either Rayleigh coefficients or ratios with frequencies, not both");
        if (coeffs)
          {
            if (d.has("rayleigh_alpha_1_s"))
              s.rayleigh_alpha = d.at("rayleigh_alpha_1_s").number();
            if (d.has("rayleigh_beta_s"))
              s.rayleigh_beta = d.at("rayleigh_beta_s").number();
            if (s.rayleigh_alpha < 0 || s.rayleigh_beta < 0)
              fail(d.where, "Rayleigh coefficients must be >= 0");
          }
        if (ratios)
          {
            const auto z = d.at("ratios").array();
            const auto f = d.at("frequencies_Hz").array();
            if (z.size() != 2 || f.size() != 2)
              fail(d.where, "'ratios' and 'frequencies_Hz' take two numbers each");
            const double z1 = z[0].number(), z2 = z[1].number();
            const double f1 = f[0].positive(), f2 = f[1].positive();
            if (z1 < 0 || z2 < 0 || z1 >= 1 || z2 >= 1)
              fail(d.where + ".ratios", "damping ratios must lie in [0, 1)");
            if (f1 == f2)
              fail(d.where + ".frequencies_Hz", "the two frequencies must differ");
            const auto ab    = rayleigh_from_ratios(z1, f1, z2, f2);
            s.rayleigh_alpha = ab[0];
            s.rayleigh_beta  = ab[1];
            if (s.rayleigh_alpha < 0 || s.rayleigh_beta < 0)
              fail(d.where, "these ratios need a negative Rayleigh coefficient "
                            "(alpha = " + std::to_string(ab[0]) + ", beta = " +
                              std::to_string(ab[1]) + "), which is not dissipative");
            s.damping_ratios_spec = Vec3{z1, z2, 0};
            s.damping_freqs_spec  = Vec3{f1, f2, 0};
          }
      }
    }

    /// Newmark or generalized-alpha.
    void
    parse_integrator(const Node &top, Scene &s)
    {
    if (top.has("integrator"))
      {
        const Node in = top.at("integrator");
        in.allow_only({"type", "rho_inf"});
        const std::string t = in.at("type").string();
        if (t == "newmark")
          {
            if (in.has("rho_inf"))
              fail(in.where, "'rho_inf' belongs to generalized_alpha");
            s.integrator = Integrator::newmark;
          }
        else if (t == "generalized_alpha")
          {
            s.integrator = Integrator::generalized_alpha;
            s.rho_inf    = in.at("rho_inf").number();
            if (!(s.rho_inf >= 0 && s.rho_inf <= 1))
              fail(in.where + ".rho_inf", "must lie in [0, 1]");
          }
        else
          fail(in.where + ".type", "unknown integrator '" + t +
                                     "' (newmark or generalized_alpha)");
      }
    }

    /// The step (the seed's 2 ms by default) and the duration.
    void
    parse_time(const Node &top, Scene &s)
    {
    // The step defaults to the seed's tau = 2 ms; a duration is needed only to run the scene
    // (a model spec for 'irdm precompute' does not need one).
    s.time_step = 0.002;
    if (top.has("time"))
      {
        const Node t = top.at("time");
        t.allow_only({"step_s", "duration_s"});
        if (t.has("step_s"))
          s.time_step = t.at("step_s").positive();
        if (t.has("duration_s"))
          {
            s.duration     = t.at("duration_s").positive();
            const double n = s.duration / s.time_step;
            if (std::abs(n - std::round(n)) > 1e-6 * n || std::round(n) < 1)
              fail(t.where, "duration_s must be a whole number (>= 1) of steps");
            if (n > 1e8)
              fail(t.where, "more than 1e8 steps");
          }
      }
    }

    /// The initial state, gravity, kinematics, fixed surfaces and the initial motion.
    void
    parse_state(const Node &top, Scene &s)
    {
    if (top.has("initial_state"))
      {
        const std::string i = top.at("initial_state").string();
        if (i == "rest")
          s.initial = InitialState::rest;
        else if (i == "static")
          s.initial = InitialState::static_equilibrium;
        else
          fail(top.where + ".initial_state", "must be 'rest' or 'static'");
      }
    if (top.has("gravity"))
      {
        const Node g = top.at("gravity");
        g.allow_only({"enabled", "acceleration_m_s2"});
        s.gravity_enabled = g.at("enabled").boolean();
        if (g.has("acceleration_m_s2"))
          s.gravity = g.at("acceleration_m_s2").vec3();
      }
    if (top.has("kinematics"))
      {
        const std::string k = top.at("kinematics").string();
        if (k == "linear")
          s.kinematics = Kinematics::linear;
        else if (k == "nonlinear")
          s.kinematics = Kinematics::nonlinear;
        else
          fail(top.where + ".kinematics", "must be 'linear' or 'nonlinear'");
      }
    if (top.has("initial_velocity_m_s"))
      {
        s.initial_velocity = top.at("initial_velocity_m_s").vec3();
        if (s.initial != InitialState::rest)
          fail(top.where + ".initial_velocity_m_s", "needs initial_state 'rest'");
      }
    if (top.has("fixed_surfaces"))
      for (const auto &n : top.at("fixed_surfaces").array())
        s.fixed_surfaces.push_back(n.string());
    if (top.has("initial_angular_velocity_rad_s"))
      {
        s.initial_angular_velocity = top.at("initial_angular_velocity_rad_s").vec3();
        if (s.initial != InitialState::rest)
          fail(top.where + ".initial_angular_velocity_rad_s", "needs initial_state 'rest'");
        if (!s.fixed_surfaces.empty() && s.initial_angular_velocity != Vec3{0, 0, 0})
          fail(top.where + ".initial_angular_velocity_rad_s",
               "a spin needs a free body (no fixed_surfaces)");
      }
    }

    /// Vertex and surface forces, and prescribed displacements.
    void
    parse_loads(const Node &top, const std::string &base_dir, Names &names, Scene &s)
    {
    if (top.has("loads"))
      for (const auto &n : top.at("loads").array())
        {
          const std::string type = n.at("type").string();
          if (type == "vertex_force")
            {
              n.allow_only({"type", "name", "vertex", "force_N", "history"});
              VertexForce f;
              f.name   = names(n, "force");
              f.vertex = parse_vertex(n.at("vertex"));
              f.force  = parse_history(n, "force_N", base_dir);
              s.vertex_forces.push_back(f);
            }
          else if (type == "surface_force")
            {
              n.allow_only({"type", "name", "surface", "total_force_N", "history"});
              SurfaceForce f;
              f.name        = names(n, "force");
              f.surface     = n.at("surface").string();
              f.total_force = parse_history(n, "total_force_N", base_dir);
              s.surface_forces.push_back(f);
            }
          else
            fail(n.where + ".type", "unknown load type '" + type +
                                      "' (vertex_force or surface_force)");
        }
    if (top.has("prescribed_displacements"))
      for (const auto &n : top.at("prescribed_displacements").array())
        {
          n.allow_only({"name", "vertex", "displacement_m", "history"});
          PrescribedDisplacement p;
          p.name         = names(n, "probe");
          p.vertex       = parse_vertex(n.at("vertex"));
          p.displacement = parse_history(n, "displacement_m", base_dir);
          s.prescribed.push_back(p);
        }
    }

    /// Probes: a path, a depth along a direction, and how they touch.
    void
    parse_probes(const Node &top, Names &names, Scene &s)
    {
    if (top.has("probes"))
      for (const auto &n : top.at("probes").array())
        {
          n.allow_only({"name", "surface", "direction", "unilateral", "path", "depth", "until_s",
                        "radius_m", "coupling"});
          Probe p;
          p.name    = names(n, "probe");
          p.surface = n.at("surface").string();
          const Vec3   d    = n.at("direction").vec3();
          const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
          if (!(norm > 0))
            fail(n.where + ".direction", "must not be zero");
          p.direction = {d[0] / norm, d[1] / norm, d[2] / norm};
          if (n.has("unilateral"))
            p.unilateral = n.at("unilateral").boolean();
          if (n.has("until_s"))
            p.until = n.at("until_s").positive();
          if (n.has("radius_m"))
            p.radius = n.at("radius_m").positive();
          if (n.has("coupling"))
            parse_coupling(n.at("coupling"), p.coupling_stiffness, p.coupling_damping);
          std::vector<Node> samples;
          parse_samples(n.at("path"), "points_m", p.path.times, samples);
          for (const auto &x : samples)
            p.path.values.push_back(x.vec3());
          samples.clear();
          parse_samples(n.at("depth"), "values_m", p.depth.times, samples);
          for (const auto &x : samples)
            p.depth.values.push_back(x.number());
          if (s.initial == InitialState::rest && p.depth.at(0.0) != 0)
            fail(n.where + ".depth", "must be 0 at t = 0: the body starts at rest");
          s.probes.push_back(p);
        }
    }

    /// Rigid planes: a moving point, a normal (turning, for nonlinear kinematics), and contact.
    void
    parse_planes(const Node &top, Names &names, Scene &s)
    {
    if (top.has("planes"))
      for (const auto &n : top.at("planes").array())
        {
          n.allow_only({"name", "normal", "normal_path", "position", "penalty_Pa_m",
                        "vertex_stiffness_N_m", "coupling"});
          RigidPlane p;
          p.name            = names(n, "plane");
          const Vec3   d    = n.at("normal").vec3();
          const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
          if (!(norm > 0))
            fail(n.where + ".normal", "must not be zero");
          p.normal = {d[0] / norm, d[1] / norm, d[2] / norm};
          std::vector<Node> samples;
          parse_samples(n.at("position"), "points_m", p.position.times, samples);
          for (const auto &x : samples)
            p.position.values.push_back(x.vec3());
          if (n.has("normal_path"))
            {
              if (s.kinematics == Kinematics::linear)
                fail(n.where + ".normal_path", "is for nonlinear kinematics (a turning plane); "
                                               "linear plane contact keeps its normal");
              samples.clear();
              parse_samples(n.at("normal_path"), "normals", p.normal_path.times, samples);
              for (const auto &x : samples)
                {
                  const Vec3 v = x.vec3();
                  if (!(std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) > 1e-6))
                    fail(n.where + ".normal_path", "normals must not be zero");
                  p.normal_path.values.push_back(v);
                }
              // Consecutive normals more than 90 degrees apart would pass through zero.
              for (size_t i = 1; i < p.normal_path.values.size(); ++i)
                {
                  const Vec3 &a = p.normal_path.values[i - 1], &b = p.normal_path.values[i];
                  if (!(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] > 0))
                    fail(n.where + ".normal_path", "consecutive normals must be less than 90 "
                                                   "degrees apart");
                }
            }
          if (n.has("penalty_Pa_m"))
            {
              if (s.kinematics == Kinematics::linear)
                fail(n.where + ".penalty_Pa_m", "is the nonlinear solver's face penalty; linear "
                                                "kinematics touch by vertex: use "
                                                "vertex_stiffness_N_m (absent: rigid)");
              p.penalty = n.at("penalty_Pa_m").positive();
            }
          if (n.has("vertex_stiffness_N_m"))
            {
              if (s.kinematics != Kinematics::linear)
                fail(n.where + ".vertex_stiffness_N_m", "is for linear kinematics (vertex "
                                                        "contact); nonlinear uses penalty_Pa_m");
              p.vertex_stiffness = n.at("vertex_stiffness_N_m").positive();
            }
          if (n.has("coupling"))
            {
              if (s.kinematics != Kinematics::linear)
                fail(n.where + ".coupling", "is for linear kinematics (a device-held plate "
                                            "by vertex contact)");
              parse_coupling(n.at("coupling"), p.coupling_stiffness, p.coupling_damping);
            }
          s.planes.push_back(p);
        }
    }

    /// What cannot go together in one scene, and what must be zero at the start from rest.
    void
    check_combinations(const Node &top, const Scene &s)
    {
    if (s.kinematics == Kinematics::linear && (s.small_strain_law || s.corotational_law))
      fail(top.where + ".material.law", "is for nonlinear kinematics (linear kinematics are "
                                        "small-strain elasticity already)");
    if (s.one_point_mass && (s.fe_degree != 1 || s.kinematics != Kinematics::linear))
      fail(top.where + ".mass_matrix", "'one_point' is for linear tetrahedra (fe_degree 1) "
                                       "under linear kinematics");
    if (s.kinematics == Kinematics::linear && !s.planes.empty() && !s.probes.empty())
      fail(top.where, "linear kinematics take either probes or planes in one scene, not both");
    if (s.kinematics == Kinematics::nonlinear && (!s.probes.empty() || !s.prescribed.empty()))
      fail(top.where, "nonlinear kinematics takes loads and planes, not probes or prescribed "
                      "displacements");
    if (!s.probes.empty() && !s.prescribed.empty())
      fail(top.where, "use either 'probes' or 'prescribed_displacements' in one scene, not both");
    if (s.probes.size() > 4)
      fail(top.where + ".probes", "at most 4 probes");
    if (s.initial == InitialState::rest)
      for (const auto &p : s.prescribed)
        {
          const Vec3 g0 = p.displacement.at(0.0);
          if (g0[0] != 0 || g0[1] != 0 || g0[2] != 0)
            fail(top.where + ".prescribed_displacements",
                 "'" + p.name + "' is not zero at t = 0, but the body starts at rest");
        }
    }

    /// The model spec for irdm precompute: length, storage, input and output regions.
    void
    parse_model(const Node &top, Scene &s)
    {
    if (top.has("model"))
      {
        const Node m = top.at("model");
        m.allow_only({"length", "storage", "inputs", "outputs"});
        if (m.has("length"))
          {
            const long long T = m.at("length").integer();
            if (T < 1 || T > 1000000)
              fail(m.where + ".length", "must be a whole number of samples in [1, 1e6]");
            s.model.length = static_cast<unsigned>(T);
          }
        if (m.has("storage"))
          {
            const std::string st = m.at("storage").string();
            if (st != "float" && st != "double")
              fail(m.where + ".storage", "must be 'float' or 'double'");
            s.model.double_storage = st == "double";
          }
        if (m.has("inputs"))
          s.model.inputs = parse_region(m.at("inputs"));
        if (m.has("outputs"))
          s.model.outputs = parse_region(m.at("outputs"));
      }
    }

    /// What a run writes, and where.
    void
    parse_outputs(const Node &top, const std::string &base_dir, Names &names, Scene &s)
    {
    if (top.has("outputs"))
      {
        const Node o = top.at("outputs");
        o.allow_only({"directory", "vertices", "surface", "every", "vtu_every", "hdf5", "csv"});
        if (o.has("directory"))
          s.outputs.directory = resolve(base_dir, o.at("directory").string());
        if (o.has("vertices"))
          for (const auto &n : o.at("vertices").array())
            {
              n.allow_only({"name", "vertex"});
              ObservedVertex v;
              v.name   = names(n, "vertex");
              v.vertex = parse_vertex(n.at("vertex"));
              s.outputs.vertices.push_back(v);
            }
        if (o.has("surface"))
          s.outputs.surface = o.at("surface").boolean();
        if (o.has("every"))
          {
            const long long k = o.at("every").integer();
            if (k < 1 || k > 1000000000)
              fail(o.where + ".every", "must be a whole number from 1 to 1e9");
            s.outputs.every = static_cast<unsigned>(k);
          }
        if (o.has("vtu_every"))
          {
            const long long k = o.at("vtu_every").integer();
            if (k < 0 || k > 1000000000)
              fail(o.where + ".vtu_every", "must be a whole number from 0 to 1e9 (0: no VTU output)");
            s.outputs.vtu_every = static_cast<unsigned>(k);
          }
        if (o.has("hdf5"))
          s.outputs.hdf5 = o.at("hdf5").boolean();
        if (o.has("csv"))
          s.outputs.csv = o.at("csv").boolean();
      }
    }

  } // namespace

  Scene
  parse_scene(const std::string &json_text,
              const std::string &base_dir,
              const std::string &origin)
  {
    json root;
    try
      {
        root = json::parse(json_text);
      }
    catch (const json::parse_error &e)
      {
        throw InputError("scene " + origin + ": malformed JSON: " + e.what());
      }
    catch (const json::out_of_range &e)
      {
        // A number too large for a double (1e400): name the key it belongs to.
        throw InputError("scene " + origin + ": " + overflowing_number(json_text) + " (" +
                         e.what() + ")");
      }
    const Node top{root, "'" + origin + "'"};
    top.allow_only({"format", "name", "mesh", "fe_degree", "mass_matrix", "material", "damping",
                    "integrator", "time", "initial_state", "gravity",
                    "kinematics", "initial_velocity_m_s", "initial_angular_velocity_rad_s", "planes",
                    "fixed_surfaces", "loads", "prescribed_displacements",
                    "probes", "model", "outputs", "comment"});
    Scene s;
    s.source    = origin;
    s.json_text = json_text;
    if (top.at("format").string() != "irdm-scene/1")
      fail(top.where + ".format", "unknown format '" + top.at("format").string() +
                                    "' (this program reads irdm-scene/1)");
    s.name = parse_name(top, "scene");

    parse_body(top, base_dir, s);
    parse_material(top, s);
    parse_damping(top, s);
    parse_integrator(top, s);
    parse_time(top, s);
    parse_state(top, s);
    Names names;
    parse_loads(top, base_dir, names, s);
    parse_probes(top, names, s);
    parse_planes(top, names, s);
    check_combinations(top, s);
    parse_model(top, s);
    parse_outputs(top, base_dir, names, s);
    return s;
  }

  Scene
  read_scene(const std::string &path)
  {
    std::ifstream in(path);
    if (!in)
      throw InputError("cannot open scene file '" + path + "'");
    std::stringstream buf;
    buf << in.rdbuf();
    return parse_scene(buf.str(), fs::path(path).parent_path().string(), path);
  }
} // namespace irdm::fem
