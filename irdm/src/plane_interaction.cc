// Virtual-DOF plane contact: model loader, orientation mapping, force loop, surface update.
#include <irdm/plane_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace irdm
{
  namespace
  {
    // The runtime finds every wall direction's dome triangle (orientation_weights): the dome
    // must tile the sphere. Each edge is shared by exactly two triangles, and the triangles'
    // solid angles (Van Oosterom and Strackee 1983) add up to 4 pi: a dome with a gap, a
    // fold or a degenerate triangle is refused here rather than in a step.
    void
    check_dome_covers_the_sphere(const VirtualDofModel &m, const std::string &path)
    {
      const auto fail = [&](const std::string &what) {
        throw InputError("'" + path + "': virtual_dofs/dome_triangles " + what);
      };
      std::map<std::pair<unsigned, unsigned>, int> edges;
      double                                       solid_angle = 0;
      for (const auto &t : m.dome_triangles)
        {
          const auto &a = m.directions[t[0]], &b = m.directions[t[1]], &c = m.directions[t[2]];
          const auto  dot = [](const std::array<double, 3> &x, const std::array<double, 3> &y) {
            return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
          };
          const double triple = a[0] * (b[1] * c[2] - b[2] * c[1]) -
                                a[1] * (b[0] * c[2] - b[2] * c[0]) +
                                a[2] * (b[0] * c[1] - b[1] * c[0]);
          if (!(std::abs(triple) > 1e-12))
            fail("holds a degenerate triangle");
          solid_angle += 2 * std::atan2(std::abs(triple), 1 + dot(a, b) + dot(b, c) + dot(c, a));
          for (int e = 0; e < 3; ++e)
            ++edges[std::minmax(t[e], t[(e + 1) % 3])];
        }
      for (const auto &[edge, count] : edges)
        if (count != 2)
          fail("must close: edge " + std::to_string(edge.first) + "-" +
               std::to_string(edge.second) + " belongs to " + std::to_string(count) +
               " triangles, not 2");
      // Within the round-off of directions stored as float (unit to 1e-6); a gap or a fold
      // changes the sum by a whole triangle's angle, about 4 pi / 5120 on the finest dome.
      if (!(std::abs(solid_angle - 4 * M_PI) < 1e-6 * 4 * M_PI))
        fail("over virtual_dofs/directions must cover the sphere once: their solid angles add "
             "up to " +
               std::to_string(solid_angle) + ", not 4 pi");
    }
  } // namespace

  VirtualDofModel
  load_virtual_dof_model(const std::string &path, const double expected_time_step)
  {
    const h5::Reader r(path);
    const std::string format =
      r.has_attribute("/", "format") ? r.string_attribute("/", "format") : std::string("none");
    if (format != "irdm-virtual-dof-model")
      throw InputError("'" + path + "' is not a virtual-DOF model (format '" + format +
                       "'); make one with irdm precompute-vdof");
    VirtualDofModel m;
    m.time_step  = r.double_attribute("/", "time_step_s");
    m.mesh_hash  = r.string_attribute("/", "mesh_hash");
    if (r.has_attribute("/", "band_m"))
      m.band = r.double_attribute("/", "band_m");
    if (!(m.band >= 0) || !std::isfinite(m.band))
      throw InputError("'" + path + "': band_m must be >= 0");
    m.integrator = r.string_attribute("/", "integrator");
    if (!(m.time_step > 0) || !std::isfinite(m.time_step))
      throw InputError("'" + path + "': time_step_s must be > 0");
    if (expected_time_step > 0 &&
        std::abs(m.time_step - expected_time_step) > 1e-12 * expected_time_step)
      throw InputError("'" + path + "' was made for a step of " + std::to_string(m.time_step) +
                       " s, not " + std::to_string(expected_time_step) + " s");
    const auto shape = r.shape("/virtual_dofs/surface_response");
    if (shape.size() != 3 || shape[2] % 3 != 0 || shape[0] < 1 || shape[1] < 1 || shape[2] < 3 ||
        shape[0] > 1000000 || shape[1] > 10000000)
      throw InputError("'" + path + "': /virtual_dofs/surface_response must be K x T x 3n "
                       "(K, T, n >= 1)");
    m.n_orientations = shape[0];
    m.length         = shape[1];
    m.n_surface      = shape[2] / 3;
    const hsize_t K = m.n_orientations, T = m.length, n = m.n_surface;
    const auto dirs = r.read_double("/virtual_dofs/directions", {K, 3});
    for (hsize_t k = 0; k < K; ++k)
      {
        const double len = std::hypot(dirs[3 * k], dirs[3 * k + 1], dirs[3 * k + 2]);
        if (!(std::abs(len - 1) < 1e-6))
          throw InputError("'" + path + "': virtual_dofs/directions must be unit vectors");
        m.directions.push_back({dirs[3 * k], dirs[3 * k + 1], dirs[3 * k + 2]});
      }
    const auto dome_shape = r.shape("/virtual_dofs/dome_triangles");
    if (dome_shape.size() != 2 || dome_shape[1] != 3)
      throw InputError("'" + path + "': virtual_dofs/dome_triangles must have shape (n, 3)");
    const auto dome = r.read_int("/virtual_dofs/dome_triangles", dome_shape);
    for (size_t t = 0; t < dome.size(); t += 3)
      {
        for (int c = 0; c < 3; ++c)
          if (dome[t + c] < 0 || dome[t + c] >= static_cast<long long>(K))
            throw InputError("'" + path + "': dome triangle index out of range");
        m.dome_triangles.push_back({static_cast<unsigned>(dome[t]), static_cast<unsigned>(dome[t + 1]),
                                    static_cast<unsigned>(dome[t + 2])});
      }
    check_dome_covers_the_sphere(m, path);
    if (!r.exists("/virtual_dofs/rest_position") || !r.exists("/outputs/fixed"))
      throw InputError("'" + path + "' has no /virtual_dofs/rest_position or /outputs/fixed (format 1); "
                       "make it again with irdm precompute-vdof");
    m.first_contact    = r.read_double("/virtual_dofs/first_contact", {K});
    m.rest_position    = r.read_double("/virtual_dofs/rest_position", {K});
    m.impulse_force    = r.read_double("/virtual_dofs/impulse_force", {K});
    m.surface_response = r.read_float("/virtual_dofs/surface_response", {K, T, 3 * n});
    m.dof_response     = r.read_double("/virtual_dofs/dof_response", {K, T, K});
    for (const auto *v : {&m.first_contact, &m.rest_position, &m.impulse_force})
      for (const double x : *v)
        if (!std::isfinite(x))
          throw InputError("'" + path + "': non-finite first_contact, rest_position or "
                           "impulse_force");
    for (const double f : m.impulse_force)
      if (!(f > 0))
        throw InputError("'" + path + "': virtual_dofs/impulse_force must be > 0 (the responses "
                         "are per newton of it)");
    m.node_tags        = r.read_int("/outputs/node_tags", {n});
    const auto xyz     = r.read_double("/outputs/coordinates", {n, 3});
    for (const double x : xyz)
      if (!std::isfinite(x))
        throw InputError("'" + path + "': outputs/coordinates contains NaN or Inf");
    for (hsize_t i = 0; i < n; ++i)
      m.coordinates.push_back({xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
    for (const long long f : r.read_int("/outputs/fixed", {n}))
      m.fixed.push_back(f != 0);
    if (std::count(m.fixed.begin(), m.fixed.end(), 0) == 0)
      throw InputError("'" + path + "': every surface vertex is fixed");
    if (r.exists("/virtual_dofs/wall_stiffness"))
      {
        m.wall_stiffness = r.read_double("/virtual_dofs/wall_stiffness", {K});
        for (const double k : m.wall_stiffness)
          if (!(k > 0) || !std::isfinite(k))
            throw InputError("'" + path + "': virtual_dofs/wall_stiffness must be > 0 and finite");
      }
    m.free_body = r.has_attribute("/", "body") && r.string_attribute("/", "body") == "free";
    if (m.free_body)
      {
        if (!r.exists("/rigid_body/mass_kg"))
          throw InputError("'" + path + "': a free body's model has no /rigid_body group");
        m.mass         = r.read_double("/rigid_body/mass_kg", {1})[0];
        const auto c   = r.read_double("/rigid_body/center_of_mass_m", {3});
        const auto in  = r.read_double("/rigid_body/inertia_kg_m2", {3, 3});
        for (int i = 0; i < 3; ++i)
          {
            m.center_of_mass[i] = c[i];
            for (int j = 0; j < 3; ++j)
              m.inertia[i][j] = in[3 * i + j];
          }
        if (!(m.mass > 0) || !std::isfinite(m.mass))
          throw InputError("'" + path + "': /rigid_body/mass_kg must be > 0");
      }
    const auto tri_shape = r.shape("/surface/triangles");
    if (tri_shape.size() != 2 || tri_shape[1] != 3)
      throw InputError("'" + path + "': surface/triangles must have shape (n, 3)");
    const auto tris = r.read_int("/surface/triangles", tri_shape);
    for (size_t t = 0; t < tris.size(); t += 3)
      {
        for (int c = 0; c < 3; ++c)
          if (tris[t + c] < 0 || tris[t + c] >= static_cast<long long>(n))
            throw InputError("'" + path + "': surface triangle index out of range");
        m.triangles.push_back({static_cast<unsigned>(tris[t]), static_cast<unsigned>(tris[t + 1]),
                               static_cast<unsigned>(tris[t + 2])});
      }
    for (const float x : m.surface_response)
      if (!std::isfinite(x))
        throw InputError("'" + path + "': non-finite surface response");
    for (const double x : m.dof_response)
      if (!std::isfinite(x))
        throw InputError("'" + path + "': non-finite virtual-DOF response");
    return m;
  }

  OrientationWeights
  orientation_weights_same_contact(const VirtualDofModel &m, const std::array<double, 3> &d);

  OrientationWeights
  orientation_weights(const VirtualDofModel &m, const std::array<double, 3> &d,
                      const OrientationMapping mapping)
  {
    OrientationWeights out;
    const auto dot = [](const std::array<double, 3> &a, const std::array<double, 3> &b) {
      return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    };
    if (mapping == OrientationMapping::interpolated_same_contact)
      return orientation_weights_same_contact(m, d);
    if (mapping == OrientationMapping::nearest)
      {
        unsigned best = 0;
        for (unsigned k = 1; k < m.n_orientations; ++k)
          if (dot(m.directions[k], d) > dot(m.directions[best], d))
            best = k;
        out.n    = 1;
        out.k[0] = best;
        out.w[0] = 1;
        return out;
      }
    // The dome triangle the ray along d passes through: d = a A + b B + c C with a, b, c >= 0
    // (Cramer's rule); the weights are a, b, c normalized.
    for (const auto &t : m.dome_triangles)
      {
        const auto &A = m.directions[t[0]], &B = m.directions[t[1]], &C = m.directions[t[2]];
        const auto det3 = [](const std::array<double, 3> &x, const std::array<double, 3> &y,
                             const std::array<double, 3> &z) {
          return x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0]) +
                 x[2] * (y[0] * z[1] - y[1] * z[0]);
        };
        const double D = det3(A, B, C);
        const double a = det3(d, B, C) / D, b = det3(A, d, C) / D, c = det3(A, B, d) / D;
        const double eps = -1e-12;
        if (a >= eps && b >= eps && c >= eps && a + b + c > 0)
          {
            const double s = std::max(a, 0.0) + std::max(b, 0.0) + std::max(c, 0.0);
            out.n = 3;
            out.k = t;
            out.w = {std::max(a, 0.0) / s, std::max(b, 0.0) / s, std::max(c, 0.0) / s};
            return out;
          }
      }
    throw InputError("orientation_weights: no dome triangle contains the direction");
  }

  SurfaceSupport
  surface_support(const VirtualDofModel &m, const std::array<double, 3> &d)
  {
    SurfaceSupport best;
    for (unsigned i = 0; i < m.n_surface; ++i)
      if (!m.fixed[i])
        {
          const auto  &x = m.coordinates[i];
          const double s = d[0] * x[0] + d[1] * x[1] + d[2] * x[2];
          if (s > best.distance)
            best = {i, s};
        }
    return best;
  }

  OrientationWeights
  orientation_weights_same_contact(const VirtualDofModel &m, const std::array<double, 3> &d)
  {
    const auto blend   = orientation_weights(m, d, OrientationMapping::interpolated);
    const double support = surface_support(m, d).distance;
    OrientationWeights out;
    double             sum = 0;
    for (unsigned i = 0; i < blend.n; ++i)
      {
        if (!(blend.w[i] > 0))
          continue;
        const auto &x = m.coordinates[surface_support(m, m.directions[blend.k[i]]).vertex];
        if (d[0] * x[0] + d[1] * x[1] + d[2] * x[2] < support - m.band)
          continue; // virtual DOF k first touches where this wall does not
        out.k[out.n] = blend.k[i];
        out.w[out.n] = blend.w[i];
        sum += blend.w[i];
        ++out.n;
      }
    if (out.n == 0)
      return orientation_weights(m, d, OrientationMapping::nearest);
    for (unsigned i = 0; i < out.n; ++i)
      out.w[i] /= sum;
    return out;
  }

  PlaneInteraction::PlaneInteraction(const VirtualDofModel &model, const OrientationMapping mapping)
    : m_(model)
    , mapping_(mapping)
    , ring_(static_cast<size_t>(model.n_orientations) * 2 * model.length, 0.0)
    , last_active_(model.n_orientations, 0)
    , surface_(3 * model.n_surface, 0.0)
    , band_centroid_(model.n_orientations, {0, 0, 0})
  {
    // Band k: the free surface vertices within `band` of plane k at first contact (as in the
    // precompute).
    for (unsigned k = 0; k < model.n_orientations; ++k)
      {
        const auto &d     = model.directions[k];
        unsigned    count = 0;
        for (unsigned i = 0; i < model.n_surface; ++i)
          {
            const auto &x = model.coordinates[i];
            if (!model.fixed[i] &&
                d[0] * x[0] + d[1] * x[1] + d[2] * x[2] >= model.first_contact[k] - model.band)
              {
                for (int a = 0; a < 3; ++a)
                  band_centroid_[k][a] += x[a];
                ++count;
              }
          }
        for (int a = 0; a < 3; ++a)
          band_centroid_[k][a] /= std::max(count, 1u);
      }
  }

  double
  PlaneInteraction::history(const unsigned j) const
  {
    const unsigned T = m_.length, pos = n_ % T;
    double         h = 0;
    for (unsigned k = 0; k < m_.n_orientations; ++k)
      {
        if (last_active_[k] == 0 || n_ >= last_active_[k] + T - 1) // nothing in the window
          continue;
        const double *f = &ring_[static_cast<size_t>(k) * 2 * T + pos + T]; // f[n - s] = f[-s]
        for (unsigned s = 1; s < T; ++s)
          h += m_.Y(k, s, j) * f[-static_cast<int>(s)];
      }
    return h;
  }

  void
  PlaneInteraction::map_direction(Mapped &wall, const std::array<double, 3> &d)
  {
    if (wall.weights.n != 0 && d == wall.direction)
      return;
    wall.weights   = orientation_weights(m_, d, mapping_);
    wall.direction = d;
    wall.support   = surface_support(m_, d).distance;
    wall.rest      = wall.support;
    for (unsigned i = 0; i < wall.weights.n; ++i)
      wall.rest -= wall.weights.w[i] *
                   (m_.first_contact[wall.weights.k[i]] - m_.rest_position[wall.weights.k[i]]);
  }

  void
  PlaneInteraction::record(const double *F)
  {
    // This step's forces (zero for the others) in both copies of the ring.
    const unsigned T = m_.length, pos = n_ % T;
    for (unsigned k = 0; k < m_.n_orientations; ++k)
      if (last_active_[k] != 0)
        {
          ring_[static_cast<size_t>(k) * 2 * T + pos]     = 0;
          ring_[static_cast<size_t>(k) * 2 * T + pos + T] = 0;
        }
    for (int a = 0; a < n_walls_; ++a)
      if (F[a] != 0)
        for (unsigned i = 0; i < walls_[a].weights.n; ++i)
          {
            const unsigned k  = walls_[a].weights.k[i];
            const double   fk = walls_[a].weights.w[i] * F[a];
            ring_[static_cast<size_t>(k) * 2 * T + pos] += fk;
            ring_[static_cast<size_t>(k) * 2 * T + pos + T] += fk;
            if (walls_[a].weights.w[i] > 0)
              last_active_[k] = n_ + 1;
          }
    ++n_;
  }

  double
  PlaneInteraction::wall_history(const Mapped &a) const
  {
    double h = 0;
    for (unsigned i = 0; i < a.weights.n; ++i)
      h += a.weights.w[i] * history(a.weights.k[i]);
    return h;
  }

  double
  PlaneInteraction::feed_through(const Mapped &a, const Mapped &b) const
  {
    double c = 0;
    for (unsigned i = 0; i < a.weights.n; ++i)
      for (unsigned l = 0; l < b.weights.n; ++l)
        c += a.weights.w[i] * b.weights.w[l] * m_.Y(b.weights.k[l], 0, a.weights.k[i]);
    return c;
  }

  void
  PlaneInteraction::place_contact(Mapped &wall, const double position) const
  {
    // The blend of the mapped virtual DOFs' band centroids, where each one's precomputed hit
    // pushed, moved onto the wall's plane. Body-fixed per virtual DOF: the point does not jump
    // with a small tilt of a flat face, as the centroid of the surface the wall overlaps would.
    const auto &d = wall.direction;
    double      c[3] = {0, 0, 0};
    for (unsigned i = 0; i < wall.weights.n; ++i)
      for (int a = 0; a < 3; ++a)
        c[a] += wall.weights.w[i] * band_centroid_[wall.weights.k[i]][a];
    const double along = position - (d[0] * c[0] + d[1] * c[1] + d[2] * c[2]);
    wall.point         = {c[0] + along * d[0], c[1] + along * d[1], c[2] + along * d[2]};
  }

  bool
  PlaneInteraction::step(const VirtualDofWall *walls, const int n, double *force)
  {
    return solve(walls, n, force, nullptr);
  }

  bool
  PlaneInteraction::step(const VirtualDofWall *walls, const int n, double *force,
                         const RigidStepCompliance &rigid)
  {
    return solve(walls, n, force, &rigid);
  }

  bool
  PlaneInteraction::solve(const VirtualDofWall *walls, const int n, double *force,
                          const RigidStepCompliance *rigid)
  {
    if (n < 0 || n > max_walls)
      return false;
    n_walls_ = n;
    // Wall a holds its band: r_a - y_a may not pass w_a. With y_a = h_a + sum_b c_ab F_b and a
    // compliant wall giving way by F_a / k_a, the band's overlap with the wall,
    //   g_a = (h_a - (r_a - w_a)) + sum_b c_ab F_b + F_a / k_a >= 0,
    // is complementary to F_a >= 0: the solver's g = W F + q with W = c + diag(1/k).
    double W[max_walls * max_walls], q[max_walls], h[max_walls];
    double Wr[max_walls * max_walls] = {}; // the rigid body's share of W (free body)
    double stiffness[max_walls];
    char   active[max_walls];
    for (int a = 0; a < n; ++a)
      {
        map_direction(walls_[a], walls[a].direction);
        walls_[a].penetration = walls_[a].support - walls[a].position;
        h[a]                  = wall_history(walls_[a]);
        q[a]                  = -(walls_[a].rest - h[a] - walls[a].position);
        active[a]             = q[a] < 0;
        for (int b = 0; b <= a; ++b)
          W[a * max_walls + b] = feed_through(walls_[a], walls_[b]);
        stiffness[a] = walls[a].stiffness;
        if (stiffness[a] == VirtualDofWall::precompute_wall)
          {
            if (m_.wall_stiffness.empty())
              return false; // the file has no wall stiffness (format 2): no step taken
            stiffness[a] = 0;
            for (unsigned i = 0; i < walls_[a].weights.n; ++i)
              stiffness[a] += walls_[a].weights.w[i] * m_.wall_stiffness[walls_[a].weights.k[i]];
          }
        if (stiffness[a] > 0)
          W[a * max_walls + a] += 1 / stiffness[a];
      }
    if (rigid)
      {
        // The body's rigid give over the step: wall b's force along -d_b at p_b moves p_a by
        // C(p_a, p_b) (-d_b) F_b, a recession along -d_a of d_a^T C(p_a, p_b) d_b F_b.
        for (int a = 0; a < n; ++a)
          place_contact(walls_[a], walls[a].position);
        for (int a = 0; a < n; ++a)
          for (int b = 0; b <= a; ++b)
            {
              const auto &pa = walls_[a].point, &pb = walls_[b].point;
              const auto &da = walls_[a].direction, &db = walls_[b].direction;
              const Eigen::Vector3d Xa(pa[0], pa[1], pa[2]), Xb(pb[0], pb[1], pb[2]);
              double c = 0;
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                  c += da[i] * rigid->entry(Xa, i, Xb, j) * db[j];
              W[a * max_walls + b] += c;
              Wr[a * max_walls + b] = c;
            }
      }
    if (n > 0 && solver_.solve(n, W, max_walls, q, active, force) < 0)
      {
        std::fill(force, force + n, 0.0); // time goes on, with no wall force
        record(force);
        return false;
      }
    for (int a = 0; a < n; ++a)
      {
        walls_[a].y = h[a];
        for (int b = 0; b < n; ++b)
          walls_[a].y += (a >= b ? W[a * max_walls + b] - Wr[a * max_walls + b]
                                 : W[b * max_walls + a] - Wr[b * max_walls + a]) * force[b];
        if (stiffness[a] > 0)
          walls_[a].y -= force[a] / stiffness[a];
      }
    record(force);
    return true;
  }

  double
  PlaneInteraction::step(const std::array<double, 3> &d, const double w)
  {
    const VirtualDofWall wall{d, w, 0};
    double               F = 0;
    step(&wall, 1, &F);
    return F;
  }

  void
  PlaneInteraction::apply(const std::array<double, 3> &d, const double F)
  {
    n_walls_ = 1;
    map_direction(walls_[0], d);
    walls_[0].penetration = 0;
    walls_[0].y = wall_history(walls_[0]) + feed_through(walls_[0], walls_[0]) * F;
    record(&F);
  }

  const std::vector<double> &
  PlaneInteraction::update_surface()
  {
    std::fill(surface_.begin(), surface_.end(), 0.0);
    if (n_ == 0)
      return surface_;
    const unsigned T = m_.length, n3 = 3 * m_.n_surface, latest = n_ - 1, pos = latest % T;
    for (unsigned k = 0; k < m_.n_orientations; ++k)
      {
        if (last_active_[k] == 0 || latest >= last_active_[k] - 1 + T)
          continue;
        const double *f = &ring_[static_cast<size_t>(k) * 2 * T + pos + T];
        for (unsigned s = 0; s < T && s <= latest; ++s)
          {
            const double fs = f[-static_cast<int>(s)];
            if (fs == 0)
              continue;
            const float *S = &m_.surface_response[(static_cast<size_t>(k) * T + s) * n3];
            for (unsigned i = 0; i < n3; ++i)
              surface_[i] += S[i] * fs;
          }
      }
    return surface_;
  }
} // namespace irdm
