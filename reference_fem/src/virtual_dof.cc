// Virtual-DOF precompute: one nonlinear FEM run per wall orientation (NonlinearElasticity,
// through its public interface), dealt to MPI ranks; rank 0 gathers and writes.
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <irdm_common/rigid_fit.h>
#include <reference_fem/mesh.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/virtual_dof.h>

#include "integrator.h"
#include "mpi_rank.h"
#include "provenance.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <memory>

namespace irdm::fem
{
  namespace
  {
    Vec3
    normalized(const Vec3 &v)
    {
      const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      return {v[0] / n, v[1] / n, v[2] / n};
    }

    double
    dot(const Vec3 &a, const Vec3 &b)
    {
      return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    }

    double
    seconds_since(const std::chrono::steady_clock::time_point t0)
    {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    /// The virtual-DOF precompute, shaped as a deal.II tutorial program: setup (the dome, the
    /// surface, each orientation's first contact and band), one nonlinear FEM run per
    /// orientation dealt to the ranks (run_orientations), the file (rank 0 gathers in
    /// orientation order and writes), run.
    class VirtualDofPrecompute
    {
    public:
      VirtualDofPrecompute(const Scene &scene, const VirtualDofOptions &options);
      VirtualDofReport
      run();

    private:
      /// One orientation's responses and figures.
      struct Rows
      {
        std::vector<double> surface, dofs; // T x 3n, T x K
        double force = 0, seconds = 0, band_size = 0, newton = 0, rigid_share = 0, wall_stiffness = 0;
      };

      void
      setup();
      Scene
      hit_scene(unsigned k) const;
      Rows
      run_orientation(unsigned k) const;
      void
      run_orientations();
      void
      write_metadata(h5::Writer &f) const;
      Rows
      gather(unsigned k);
      void
      write_file();

      const Scene                                    &scene;
      const VirtualDofOptions                        &options;
      const std::chrono::steady_clock::time_point     t_start = std::chrono::steady_clock::now();
      const MpiRank                                   mpi;
      const int                                       rank, size;
      const std::function<void(const std::string &)> log;
      OutputLock                                      output_lock; // rank 0: the output's
      // No fixed surface: a free body, whose rigid motion the best fit takes out (header).
      bool         free_body = false;
      GeodesicDome dome;
      unsigned     K = 0, T = 0; // orientations; samples per response
      bool         dbl = false;  // double storage
      // The undeformed surface and its fixed vertices (on a fixed surface: the wall's contact
      // there goes into the support and moves nothing, see NonlinearElasticity).
      SurfaceMesh            surface;
      unsigned               n_surface = 0;
      std::vector<long long> fixed;
      // Per orientation, over the free vertices: first contact (the support along d_k), the
      // band (the vertices within options.band of the plane at first contact) and its rest
      // position (the mean of d_k . X over the band, where the virtual DOF sits when y_k = 0).
      std::vector<double>                first_contact, rest_position;
      std::vector<std::vector<unsigned>> band;
      MassProperties                     mass;
      Eigen::Vector3d                    center_of_mass = Eigen::Vector3d::Zero();
      std::vector<Eigen::Vector3d>       rest;
      std::map<unsigned, Rows>           mine; // this rank's orientations
      std::unique_ptr<h5::Writer>        w;
      VirtualDofReport                   rep;
    };

  } // namespace

  GeodesicDome
  geodesic_dome(const unsigned subdivisions)
  {
    if (subdivisions > 6)
      throw InputError("geodesic dome: at most 6 subdivisions (40962 orientations)");
    GeodesicDome d;
    // Icosahedron: the poles and two rings of five at z = +-1/sqrt(5), offset by 36 degrees.
    const double z = 1 / std::sqrt(5.0), r = 2 / std::sqrt(5.0);
    d.directions.push_back({0, 0, 1});
    for (int i = 0; i < 5; ++i)
      d.directions.push_back({r * std::cos(2 * M_PI * i / 5), r * std::sin(2 * M_PI * i / 5), z});
    for (int i = 0; i < 5; ++i)
      d.directions.push_back({r * std::cos(2 * M_PI * (i + 0.5) / 5),
                              r * std::sin(2 * M_PI * (i + 0.5) / 5), -z});
    d.directions.push_back({0, 0, -1});
    for (unsigned i = 0; i < 5; ++i)
      {
        const unsigned u0 = 1 + i, u1 = 1 + (i + 1) % 5, l0 = 6 + i, l1 = 6 + (i + 1) % 5;
        d.triangles.push_back({0, u0, u1});
        d.triangles.push_back({u0, l0, u1});
        d.triangles.push_back({u1, l0, l1});
        d.triangles.push_back({11, l1, l0});
      }
    for (unsigned s = 0; s < subdivisions; ++s)
      {
        std::map<std::pair<unsigned, unsigned>, unsigned> midpoint;
        const auto mid = [&](unsigned a, unsigned b) {
          if (a > b)
            std::swap(a, b);
          const auto it = midpoint.find({a, b});
          if (it != midpoint.end())
            return it->second;
          const Vec3 &p = d.directions[a], &q = d.directions[b];
          d.directions.push_back(normalized({p[0] + q[0], p[1] + q[1], p[2] + q[2]}));
          return midpoint[{a, b}] = static_cast<unsigned>(d.directions.size() - 1);
        };
        std::vector<std::array<unsigned, 3>> finer;
        for (const auto &t : d.triangles)
          {
            const unsigned a = mid(t[0], t[1]), b = mid(t[1], t[2]), c = mid(t[2], t[0]);
            finer.push_back({t[0], a, c});
            finer.push_back({a, t[1], b});
            finer.push_back({c, b, t[2]});
            finer.push_back({a, b, c});
          }
        d.triangles.swap(finer);
      }
    return d;
  }

  VirtualDofPrecompute::VirtualDofPrecompute(const Scene &scene, const VirtualDofOptions &options)
    : scene(scene)
    , options(options)
    , rank(mpi.rank)
    , size(mpi.size)
    , log(mpi.rank0(options.log))
    , output_lock(lock_output_on_rank0(mpi, options.output, scene.mesh_file, "virtual DOFs"))
  {
    // No fixed surface: a free body, whose rigid motion the best fit takes out (header).
    free_body = scene.fixed_surfaces.empty();
    if (!(options.impulse_depth > 0) || !(options.band > 0))
      throw InputError("virtual DOFs: the impulse depth and the band must be > 0");
  }

  void
  VirtualDofPrecompute::setup()
  {
    dome = geodesic_dome(options.subdivisions);
    K    = dome.directions.size();
    T    = options.length.value_or(scene.model.length);
    dbl  = options.double_storage.value_or(scene.model.double_storage);

    // The undeformed surface and its fixed vertices (on a fixed surface: the wall's contact
    // there goes into the support and moves nothing, see NonlinearElasticity).
    surface   = ElasticDynamics(scene).boundary();
    n_surface = surface.coordinates.size();
    fixed.assign(n_surface, 0);
    for (unsigned t = 0; t < surface.triangles.size(); ++t)
      if (std::find(scene.fixed_surfaces.begin(), scene.fixed_surfaces.end(),
                    surface.triangle_surface[t]) != scene.fixed_surfaces.end())
        for (const unsigned i : surface.triangles[t])
          fixed[i] = 1;
    // Per orientation, over the free vertices: first contact (the support along d_k), the band
    // (the vertices within options.band of the plane at first contact) and its rest position
    // (the mean of d_k . X over the band, where the virtual DOF sits when y_k = 0).
    first_contact.assign(K, -1e300);
    rest_position.assign(K, 0);
    band.assign(K, {});
    for (unsigned k = 0; k < K; ++k)
      {
        for (unsigned i = 0; i < n_surface; ++i)
          if (!fixed[i])
            first_contact[k] = std::max(first_contact[k], dot(dome.directions[k], surface.coordinates[i]));
        for (unsigned i = 0; i < n_surface; ++i)
          if (!fixed[i] && dot(dome.directions[k], surface.coordinates[i]) >= first_contact[k] - options.band)
            {
              band[k].push_back(i);
              rest_position[k] += dot(dome.directions[k], surface.coordinates[i]);
            }
        rest_position[k] /= band[k].size();
      }

    mass           = mass_properties(read_gmsh(scene.mesh_file), scene.density);
    center_of_mass = Eigen::Vector3d(mass.center[0], mass.center[1], mass.center[2]);
    rest.resize(n_surface);
    for (unsigned i = 0; i < n_surface; ++i)
      rest[i] = Eigen::Vector3d(surface.coordinates[i][0], surface.coordinates[i][1],
                                surface.coordinates[i][2]);
  }

  /// The scene of orientation k: the body alone, hit once by the wall.
  Scene
  VirtualDofPrecompute::hit_scene(const unsigned k) const
  {
    Scene s = scene;
    s.kinematics      = Kinematics::nonlinear;
    s.gravity_enabled = false; // a constant load, not part of the responses
    s.vertex_forces.clear();
    s.surface_forces.clear();
    s.probes.clear();
    s.prescribed.clear();
    s.initial          = InitialState::rest;
    s.initial_velocity = {0, 0, 0};
    s.initial_angular_velocity = {0, 0, 0};
    s.duration         = (T + 1) * scene.time_step;
    s.outputs          = Scene::Outputs();
    s.outputs.surface  = true;
    s.outputs.hdf5 = s.outputs.csv = false;
    const Vec3  &d = dome.directions[k];
    const double away = first_contact[k] + 0.1, in = first_contact[k] - options.impulse_depth;
    RigidPlane   wall;
    wall.name     = "wall";
    wall.normal   = {-d[0], -d[1], -d[2]};
    wall.position.times  = {0, scene.time_step, 2 * scene.time_step};
    wall.position.values = {{away * d[0], away * d[1], away * d[2]},
                            {in * d[0], in * d[1], in * d[2]},
                            {away * d[0], away * d[1], away * d[2]}};
    s.planes = {wall};
    return s;
  }

  /// Orientation k: the nonlinear FEM hit, and its responses per unit force.
  VirtualDofPrecompute::Rows
  VirtualDofPrecompute::run_orientation(const unsigned k) const
  {
    const auto          t0 = std::chrono::steady_clock::now();
    const Scene         s  = hit_scene(k);
    NonlinearElasticity fem(s);
    const RunResult     r = fem.run();
    if (r.surface.node_tags != surface.node_tags)
      throw std::logic_error("virtual DOFs: the nonlinear FEM's surface differs from the "
                             "linear one's");
    const Vec3  &d = dome.directions[k];
    const double F = -dot(r.plane_force.at("wall")[1], d); // along -d_k, at step 1
    if (!(F > 0))
      throw InputError("virtual DOFs: the wall of orientation " + std::to_string(k) +
                       " took no force at its impulse step");
    for (unsigned s2 = 2; s2 < r.plane_force.at("wall").size(); ++s2)
      if (dot(r.plane_force.at("wall")[s2], r.plane_force.at("wall")[s2]) > 0)
        throw InputError("virtual DOFs: the wall of orientation " + std::to_string(k) +
                         " touched the body again after its impulse step");
    Rows        rows;
    const auto  n3 = 3 * surface.node_tags.size();
    rows.surface.resize(static_cast<size_t>(T) * n3);
    rows.dofs.resize(static_cast<size_t>(T) * K);
    std::vector<double> deformation(n3);
    for (unsigned s2 = 0; s2 < T; ++s2)
      {
        const std::vector<double> *recorded = &r.surface_displacement[1 + s2];
        if (s2 == 0)
          {
            // The precompute's penalty wall as a spring: its overlap with the recorded
            // (whole) motion of band k at the impulse step.
            double y = 0;
            for (const unsigned i : band[k])
              y -= dot(d, {(*recorded)[3 * i], (*recorded)[3 * i + 1], (*recorded)[3 * i + 2]});
            y /= band[k].size();
            rows.wall_stiffness = F / std::max(options.impulse_depth - y, 1e-300);
          }
        if (free_body)
          {
            // The deformation: the recorded motion less its best rigid fit.
            std::vector<Eigen::Vector3d> x(n_surface);
            double u2 = 0, d2 = 0;
            for (unsigned i = 0; i < n_surface; ++i)
              for (int a = 0; a < 3; ++a)
                {
                  x[i](a) = rest[i](a) + (*recorded)[3 * i + a];
                  u2 += (*recorded)[3 * i + a] * (*recorded)[3 * i + a];
                }
            // Translation: the centre of mass's (the run-time rigid body carries the
            // whole impulse, so the deformation may carry no momentum); rotation: the best
            // about it over the surface vertices.
            const auto &dc = r.center_of_mass_displacement[1 + s2];
            const std::pair<Eigen::Vector3d, Eigen::Vector3d> centers(
              center_of_mass, center_of_mass + Eigen::Vector3d(dc[0], dc[1], dc[2]));
            const RigidFit fit = best_rigid_fit(rest, x, &centers);
            for (unsigned i = 0; i < n_surface; ++i)
              for (int a = 0; a < 3; ++a)
                {
                  deformation[3 * i + a] = fit.deformation[i](a);
                  d2 += fit.deformation[i](a) * fit.deformation[i](a);
                }
            if (u2 > 0)
              rows.rigid_share = std::max(rows.rigid_share, std::sqrt(std::max(0.0, 1 - d2 / u2)));
            recorded = &deformation;
          }
        const auto &u = *recorded;
        for (size_t i = 0; i < n3; ++i)
          rows.surface[s2 * n3 + i] = u[i] / F;
        for (unsigned j = 0; j < K; ++j)
          {
            double y = 0;
            for (const unsigned i : band[j])
              y -= dot(dome.directions[j], {u[3 * i], u[3 * i + 1], u[3 * i + 2]});
            rows.dofs[static_cast<size_t>(s2) * K + j] = y / band[j].size() / F;
          }
      }
    rows.force     = F;
    rows.seconds   = seconds_since(t0);
    rows.band_size = band[k].size();
    rows.newton    = r.newton_iterations;
    return rows;
  }

  /// Each rank runs its orientations and keeps their rows.
  void
  VirtualDofPrecompute::run_orientations()
  {
    // Each rank runs its orientations and keeps their rows.
    unsigned n_done = 0, n_mine = 0;
    for (unsigned k = rank; k < K; k += size)
      ++n_mine;
    {
      // Rank 0 holds every orientation's responses until it writes them: surface (K x T x 3n)
      // and virtual DOFs (K x T x K); each rank holds its share while it works.
      const double bytes = static_cast<double>(K) * T * (3.0 * n_surface * (dbl ? 8 : 4) + 8.0 * K);
      check_memory_estimate("the virtual-DOF responses", bytes, options.allow_large);
      if (rank == 0)
        check_disk_estimate("the virtual-DOF model", options.output, bytes, options.allow_large);
    }
    log("virtual DOFs: " + std::to_string(K) + " orientations x " + std::to_string(T) +
        " samples, " + std::to_string(size) + " rank(s)");
    for (unsigned k = rank; k < K; k += size)
      {
        Rows rows = run_orientation(k);
        ++n_done;
        if (rank == 0)
          {
            const double elapsed = seconds_since(t_start);
            char         line[200];
            std::snprintf(line, sizeof line,
                          "  orientation %u (%u of %u on rank 0): force %.4g N, %.2f s, %u "
                          "Newton iterations; about %.0f s left", k, n_done, n_mine, rows.force,
                          rows.seconds, static_cast<unsigned>(rows.newton),
                          elapsed / n_done * (n_mine - n_done));
            log(line);
          }
        mine[k] = std::move(rows);
      }
  }

  void
  VirtualDofPrecompute::write_metadata(h5::Writer &f) const
  {
    f.attribute("/", "format", std::string("irdm-virtual-dof-model"));
    f.attribute("/", "format_version", 3LL);
    write_provenance(f, scene, IntegratorCoefficients::from_scene(scene));
    f.attribute("/", "units", std::string("SI: m, s, N, kg, Pa; responses in m/N"));
    f.attribute("/", "convention",
                std::string("y[n] = sum_s Y[s] f[n-s], u_surface[n] = sum_s S[s] f[n-s]; "
                            "f_k[n] (N) is the force wall k applies along -d_k during step n "
                            "(impulse = f * time_step); the responses are the nonlinear "
                            "FEM's after a wall touching for one step (its resultant F_k "
                            "at that step), divided by F_k; y_j is the mean of -d_j . u "
                            "over the surface vertices within band_m of plane j at first "
                            "contact"));
    f.attribute("/", "kinematics", std::string("nonlinear (Total Lagrangian neo-Hookean), "
                                               "penalty plane contact"));
    f.attribute("/", "body", std::string(free_body ? "free" : "fixed"));
    if (free_body)
      {
        f.attribute("/", "free_body_route", std::string("rigid_fit"));
        f.attribute("/", "rigid_fit_weights",
                    std::string("translation: the centre of mass (mass); rotation: the "
                                "best about it over the surface vertices (uniform)"));
        f.attribute("/", "free_body_convention",
                    std::string("the responses are the recorded surface motion less, at "
                                "every sample, its rigid part (the centre of mass's "
                                "translation and the best rotation about it by least "
                                "squares over the surface vertices, Kabsch), in that "
                                "frame; the run-time rigid body makes the motion"));
        const MassProperties &mp = mass;
        f.create_group("/rigid_body");
        f.write("/rigid_body/mass_kg", {1}, &mp.mass);
        f.write("/rigid_body/center_of_mass_m", {3}, mp.center.data());
        f.write("/rigid_body/inertia_kg_m2", {3, 3}, &mp.inertia[0][0]);
        f.attribute("/rigid_body", "frame",
                    std::string("model (mesh) frame; inertia about the centre of mass"));
      }
    f.attribute("/", "length", static_cast<long long>(T));
    f.attribute("/", "storage", std::string(dbl ? "double" : "float"));
    f.attribute("/", "subdivisions", static_cast<long long>(options.subdivisions));
    f.attribute("/", "impulse_depth_m", options.impulse_depth);
    f.attribute("/", "band_m", options.band);
    f.attribute("/", "precompute_ranks", static_cast<long long>(size));
    f.create_group("/outputs");
    f.write("/outputs/node_tags", {surface.node_tags.size()}, surface.node_tags.data());
    std::vector<double> xyz;
    for (const auto &x : surface.coordinates)
      xyz.insert(xyz.end(), x.begin(), x.end());
    f.write("/outputs/coordinates", {surface.coordinates.size(), 3}, xyz.data());
    f.write("/outputs/fixed", {n_surface}, fixed.data());
    f.attribute("/outputs/fixed", "meaning",
                std::string("1: the vertex lies on a fixed surface (zero displacement; a "
                            "wall's contact there goes into the support)"));
    f.create_group("/surface");
    std::vector<long long> tris;
    for (const auto &t : surface.triangles)
      tris.insert(tris.end(), t.begin(), t.end());
    f.write("/surface/triangles", {surface.triangles.size(), 3}, tris.data());
    f.create_group("/virtual_dofs");
    std::vector<double> dirs;
    for (const auto &d : dome.directions)
      dirs.insert(dirs.end(), d.begin(), d.end());
    f.write("/virtual_dofs/directions", {K, 3}, dirs.data());
    std::vector<long long> dome_tris;
    for (const auto &t : dome.triangles)
      dome_tris.insert(dome_tris.end(), t.begin(), t.end());
    f.write("/virtual_dofs/dome_triangles", {dome.triangles.size(), 3}, dome_tris.data());
    f.write("/virtual_dofs/first_contact", {K}, first_contact.data());
    f.attribute("/virtual_dofs/first_contact", "meaning",
                std::string("m: the wall of orientation k first touches the undeformed "
                            "body's free vertices at the plane d_k . x = first_contact[k]"));
    f.write("/virtual_dofs/rest_position", {K}, rest_position.data());
    f.attribute("/virtual_dofs/rest_position", "meaning",
                std::string("m: the mean of d_k . X over the band of virtual DOF k (its "
                            "position at y_k = 0); a rigid wall at w holds the band at "
                            "rest_position[k] - y_k = w"));
    const unsigned long long n3 = 3 * n_surface;
    f.create_dataset("/virtual_dofs/surface_response", {K, T, n3}, dbl, 1, true);
    f.attribute("/virtual_dofs/surface_response", "layout",
                std::string("[orientation k][step s][3 * surface vertex + axis], m/N"));
    f.create_dataset("/virtual_dofs/dof_response", {K, T, K}, dbl, 1, true);
    f.attribute("/virtual_dofs/dof_response", "layout",
                std::string("[input orientation k][step s][output virtual DOF j], m/N"));
  }

  /// Orientation k's rows on rank 0 (received from its rank).
  VirtualDofPrecompute::Rows
  VirtualDofPrecompute::gather(const unsigned k)
  {
    const int owner = static_cast<int>(k % size);
    Rows      rows;
    if (owner == rank)
      rows = std::move(mine.at(k));
    else if (rank == 0)
      {
        rows.surface.resize(static_cast<size_t>(T) * 3 * n_surface);
        rows.dofs.resize(static_cast<size_t>(T) * K);
      }
    if (owner != 0)
      {
        double scalars[6] = {rows.force, rows.seconds, rows.band_size, rows.newton,
                             rows.rigid_share, rows.wall_stiffness};
        if (owner == rank)
          {
            MPI_Send(scalars, 6, MPI_DOUBLE, 0, 3 * k, MPI_COMM_WORLD);
            MPI_Send(rows.surface.data(), rows.surface.size(), MPI_DOUBLE, 0, 3 * k + 1,
                     MPI_COMM_WORLD);
            MPI_Send(rows.dofs.data(), rows.dofs.size(), MPI_DOUBLE, 0, 3 * k + 2,
                     MPI_COMM_WORLD);
          }
        else if (rank == 0)
          {
            MPI_Recv(scalars, 6, MPI_DOUBLE, owner, 3 * k, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Recv(rows.surface.data(), rows.surface.size(), MPI_DOUBLE, owner, 3 * k + 1,
                     MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Recv(rows.dofs.data(), rows.dofs.size(), MPI_DOUBLE, owner, 3 * k + 2,
                     MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            rows.force     = scalars[0];
            rows.seconds   = scalars[1];
            rows.band_size = scalars[2];
            rows.newton    = scalars[3];
            rows.rigid_share = scalars[4];
            rows.wall_stiffness = scalars[5];
          }
      }
    return rows;
  }

  /// Rank 0 gathers in orientation order and writes.
  void
  VirtualDofPrecompute::write_file()
  {
    rep.n_orientations = K;
    rep.length         = T;
    rep.ranks          = size;
    rep.n_surface      = n_surface;
    std::vector<double> force(K), seconds(K), band_size(K), newton(K), rigid_share(K),
      wall_stiffness(K);
    if (rank == 0)
      {
        w = std::make_unique<h5::Writer>(options.output, h5::Writer::Mode::create,
                                         std::move(output_lock));
        write_metadata(*w);
      }
    for (unsigned k = 0; k < K; ++k)
      {
        Rows rows = gather(k);
        if (rank == 0)
          {
            w->write_rows("/virtual_dofs/surface_response", k, 1, rows.surface.data());
            w->write_rows("/virtual_dofs/dof_response", k, 1, rows.dofs.data());
            force[k]     = rows.force;
            seconds[k]   = rows.seconds;
            band_size[k] = rows.band_size;
            newton[k]    = rows.newton;
            rigid_share[k] = rows.rigid_share;
            wall_stiffness[k] = rows.wall_stiffness;
          }
      }
    if (rank == 0)
      {
        w->write("/virtual_dofs/impulse_force", {K}, force.data());
        w->attribute("/virtual_dofs/impulse_force", "meaning",
                     std::string("N: F_k, the wall's resultant along -d_k at its impulse step"));
        w->write("/virtual_dofs/wall_stiffness", {K}, wall_stiffness.data());
        w->attribute("/virtual_dofs/wall_stiffness", "meaning",
                     std::string("N/m: the precompute's penalty wall as a spring, F_k over its "
                                 "overlap with band k (impulse_depth less the band's recorded "
                                 "recession) at the impulse step"));
        w->write("/virtual_dofs/band_size", {K}, band_size.data());
        w->write("/virtual_dofs/seconds", {K}, seconds.data());
        w->write("/virtual_dofs/newton_iterations", {K}, newton.data());
        if (free_body)
          {
            w->write("/virtual_dofs/rigid_share", {K}, rigid_share.data());
            w->attribute("/virtual_dofs/rigid_share", "meaning",
                         std::string("the rigid motion the fit took out, as a share of the "
                                     "recorded surface displacement (RMS over the surface, "
                                     "largest over the samples)"));
          }
        w->commit();
        rep.seconds_per_orientation_max  = *std::max_element(seconds.begin(), seconds.end());
        rep.seconds_per_orientation_mean = 0;
        for (const double s : seconds)
          rep.seconds_per_orientation_mean += s / K;
        rep.impulse_force_min = *std::min_element(force.begin(), force.end());
        rep.impulse_force_max = *std::max_element(force.begin(), force.end());
        for (const double x : newton)
          rep.newton_iterations += static_cast<unsigned>(x);
        rep.free_body = free_body;
        if (free_body)
          {
            rep.rigid_share_max = *std::max_element(rigid_share.begin(), rigid_share.end());
            for (const double x : rigid_share)
              rep.rigid_share_mean += x / K;
          }
      }
    rep.seconds_total = seconds_since(t_start);
  }

  VirtualDofReport
  VirtualDofPrecompute::run()
  {
    setup();
    run_orientations();
    write_file();
    rep.seconds_total = seconds_since(t_start);
    return rep;
  }

  VirtualDofReport
  precompute_virtual_dofs(const Scene &scene, const VirtualDofOptions &options)
  {
    return VirtualDofPrecompute(scene, options).run();
  }
} // namespace irdm::fem
