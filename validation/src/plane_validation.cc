// Virtual-DOF plane contact against the nonlinear FEM (validation/plane_validation.h).
#include <irdm_common/files.h>
#include <irdm/plane_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>
#include <reference_fem/virtual_dof.h>
#include <validation/plane_validation.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    using Clock = std::chrono::steady_clock;
    using Vec3  = std::array<double, 3>;

    double
    since(const Clock::time_point t0)
    {
      return std::chrono::duration<double>(Clock::now() - t0).count();
    }

    double
    dot(const Vec3 &a, const Vec3 &b)
    {
      return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    }

    /// One case: the wall along d, its penetration p(t) into the undeformed body (m; the wall
    /// is at w = support(d) - p(t)), linear between samples.
    struct Case
    {
      std::string         kind, name;
      Vec3                d;
      double              depth = 0, speed = 0; // m, m/s (what is varied)
      std::vector<double> times, penetration;
      double              duration = 0;
    };

    struct Row
    {
      Case   c;
      double fem_peak_force = 0, fem_max_penetration = 0;
      double force_error[2] = {0, 0};        // relative L2, nearest / interpolated
      // |sum F_IRDM - sum F_FEM| / sum F_FEM: the impulse the wall gives, which bouncing
      // contact (both methods chatter at a single vertex) does not scramble as the L2 does.
      double impulse_error[2] = {0, 0};
      double displacement_error[2] = {0, 0}; // relative L2 over surface and time
      // The surface driven by the FEM's own wall force (open loop, interpolated mapping): the
      // error of the responses alone, without the contact solve's.
      double open_loop_displacement_error = 0;
      bool   on_dome = false; // d is one of the model's directions
      double fem_ms_per_step = 0, irdm_force_us = 0, irdm_surface_us = 0;
      unsigned newton = 0;
      // Per step k = 1..N: the wall force of the FEM and of the IRDM (nearest, interpolated).
      std::vector<double> F_fem, F_irdm[2];
    };

    Case
    press(const std::string &side, const Vec3 &d, const double depth)
    {
      Case c;
      c.kind  = "press_" + side;
      c.name  = c.kind + "_" + std::to_string(static_cast<int>(std::round(depth * 1000))) + "mm";
      c.d     = d;
      c.depth = depth;
      // In over 0.2 s, held to 0.35 s, out by 0.45 s, free to 0.6 s.
      c.times       = {0, 0.2, 0.35, 0.45};
      c.penetration = {0, depth, depth, -0.01};
      c.duration    = 0.6;
      return c;
    }

    Case
    impact(const Vec3 &d, const double speed, const double depth)
    {
      Case c;
      c.kind  = "impact_side";
      c.name  = c.kind + "_" + std::to_string(static_cast<int>(std::round(speed * 1000))) + "mm_s";
      c.d     = d;
      c.speed = speed;
      c.depth = depth;
      // The wall arrives at the given speed, reverses at the depth, and leaves as fast.
      const double t_in = depth / speed;
      c.times       = {0, 0.004, 0.004 + t_in, 0.004 + 2 * t_in + 0.01 / speed};
      c.penetration = {-0.0001, 0, depth, -0.01};
      c.duration    = 0.4;
      return c;
    }

    std::string
    vec_text(const Vec3 &v)
    {
      char b[80];
      std::snprintf(b, sizeof b, "(%.3f, %.3f, %.3f)", v[0], v[1], v[2]);
      return b;
    }

    double
    interp(const std::vector<double> &t, const std::vector<double> &v, const double x)
    {
      if (x <= t.front())
        return v.front();
      if (x >= t.back())
        return v.back();
      const auto   i = std::upper_bound(t.begin(), t.end(), x) - t.begin();
      const double a = (x - t[i - 1]) / (t[i] - t[i - 1]);
      return (1 - a) * v[i - 1] + a * v[i];
    }
  } // namespace

  void
  run_plane_validation(const PlaneValidationOptions &o, std::ostream &log)
  {
    fem::Scene body = fem::read_scene(o.scene);
    body.probes.clear();
    body.prescribed.clear();
    body.outputs          = fem::Scene::Outputs();
    body.outputs.hdf5     = body.outputs.csv = false;
    body.outputs.surface  = true;
    body.gravity_enabled  = false;
    body.kinematics       = fem::Kinematics::nonlinear;
    const double tau      = body.time_step;
    const std::string dir = (fs::path(o.report_dir) / "planes").string();
    fs::create_directories(dir);

    // 1. The virtual-DOF model (reused when its spec matches).
    bool reuse = false;
    if (fs::exists(o.model_file))
      try
        {
          const h5::Reader r(o.model_file);
          const auto shape = r.shape("/virtual_dofs/surface_response");
          const unsigned K = 10u * (1u << (2 * o.subdivisions)) + 2;
          reuse = r.string_attribute("/", "scene") == body.json_text && shape.size() == 3 &&
                  shape[0] == K && shape[1] == o.length;
        }
      catch (const InputError &)
        {}
    double per_orientation = 0;
    if (!reuse && fs::exists(o.model_file))
      throw InputError("--model '" + o.model_file + "' exists but is not a virtual-DOF model of "
                       "this scene with " + std::to_string(o.subdivisions) + " subdivisions and "
                       "T = " + std::to_string(o.length) + " (a point model, another scene or "
                       "another spec); it is never overwritten: remove it or choose another path");
    if (!reuse)
      {
        if (!fs::path(o.model_file).parent_path().empty())
          fs::create_directories(fs::path(o.model_file).parent_path());
        fem::VirtualDofOptions vo;
        vo.output       = o.model_file;
        vo.subdivisions = o.subdivisions;
        vo.length       = o.length;
        vo.double_storage = false; // the runtime reads the responses as float
        vo.log          = [&](const std::string &s) { log << "  " << s << "\n"; };
        log << "precomputing the virtual-DOF model " << o.model_file << "\n";
        per_orientation = fem::precompute_virtual_dofs(body, vo).seconds_per_orientation_mean;
      }
    const VirtualDofModel model = load_virtual_dof_model(o.model_file, tau);
    if (reuse)
      {
        const h5::Reader    r(o.model_file);
        const auto          secs = r.read_double("/virtual_dofs/seconds", {model.n_orientations});
        for (const double s : secs)
          per_orientation += s / secs.size();
      }
    log << "virtual-DOF model: " << model.n_orientations << " orientations x " << model.length
        << " samples, " << model.n_surface << " surface vertices\n";

    // 2. The cases.
    const Vec3          side = {0, 1, 0}, top = {0, 0, 1};
    // Between dome directions (to measure what interpolating between orientations buys), at
    // the centres of two dome triangles:
    // - oblique: next to the side direction's nearest virtual DOF, the one with the highest
    //   centre; there the first-contact vertex jumps between body parts from one virtual DOF
    //   to the next (the cat is not convex);
    // - between: one whose centre and three virtual DOFs all first touch the same vertex (of
    //   those, the centre closest to the side direction).
    const auto support_vertex = [&](const Vec3 &d) {
      unsigned best    = 0;
      double   top_dot = -1e300;
      for (unsigned i = 0; i < model.n_surface; ++i)
        if (!model.fixed[i] && dot(d, model.coordinates[i]) > top_dot)
          {
            top_dot = dot(d, model.coordinates[i]);
            best    = i;
          }
      return best;
    };
    const auto centre = [&](const std::array<unsigned, 3> &t) {
      Vec3 c{0, 0, 0};
      for (const unsigned k : t)
        for (int a = 0; a < 3; ++a)
          c[a] += model.directions[k][a];
      const double n = std::sqrt(dot(c, c));
      return Vec3{c[0] / n, c[1] / n, c[2] / n};
    };
    Vec3           oblique{0, 0, -2}, between{0, -2, 0};
    const unsigned k_side = orientation_weights(model, side, OrientationMapping::nearest).k[0];
    for (const auto &t : model.dome_triangles)
      {
        const Vec3 c = centre(t);
        if ((t[0] == k_side || t[1] == k_side || t[2] == k_side) && c[2] > oblique[2])
          oblique = c;
        const unsigned v = support_vertex(c);
        if (support_vertex(model.directions[t[0]]) == v &&
            support_vertex(model.directions[t[1]]) == v &&
            support_vertex(model.directions[t[2]]) == v && dot(c, side) > dot(between, side))
          between = c;
      }
    if (between[1] < -1)
      throw InputError("validate-planes: no dome triangle whose virtual DOFs all first touch "
                       "the same vertex");
    std::vector<Case>   cases;
    for (const double depth : {0.002, 0.005, 0.01, 0.02})
      cases.push_back(press("side", side, depth));
    for (const double depth : {0.002, 0.005})
      cases.push_back(press("oblique", oblique, depth));
    for (const double depth : {0.002, 0.005, 0.01, 0.02})
      cases.push_back(press("between", between, depth));
    for (const double depth : {0.002, 0.005, 0.01, 0.02})
      cases.push_back(press("top", top, depth));
    for (const double speed : {0.05, 0.1, 0.2, 0.5})
      cases.push_back(impact(side, speed, 0.002));

    // Adds sum_i (u_i - u_fem_i)^2 to e and sum_i u_fem_i^2 to n.
    const auto add_surface_error = [](const std::vector<double> &u, const std::vector<double> &uf,
                                      double &e, double &n) {
      for (size_t i = 0; i < u.size(); ++i)
        {
          e += (u[i] - uf[i]) * (u[i] - uf[i]);
          n += uf[i] * uf[i];
        }
    };
    std::vector<Row> rows;
    for (const auto &c : cases)
      {
        Row row;
        row.c = c;
        // The wall's position from the free vertices' support (the fixed base is the ground's).
        const double support = dot(c.d, model.coordinates[support_vertex(c.d)]);
        double       best_dot = -1;
        for (const auto &dk : model.directions)
          best_dot = std::max(best_dot, dot(dk, c.d));
        row.on_dome = best_dot > 1 - 1e-12;
        const auto wall_at = [&](const double t) {
          return support - interp(c.times, c.penetration, t);
        };
        // FEM: the plane through w(t) d with normal -d, sampled at every step.
        fem::Scene s = body;
        s.name     = c.name;
        s.duration = c.duration;
        fem::RigidPlane wall;
        wall.name   = "wall";
        wall.normal = {-c.d[0], -c.d[1], -c.d[2]};
        const unsigned N = s.n_steps();
        for (unsigned k = 0; k <= N; ++k)
          {
            const double w = wall_at(k * tau);
            wall.position.times.push_back(k * tau);
            wall.position.values.push_back({w * c.d[0], w * c.d[1], w * c.d[2]});
          }
        s.planes = {wall};
        log << c.name << ": FEM ..." << std::flush;
        const auto t0 = Clock::now();
        const auto fem_r = fem::NonlinearElasticity(s).run();
        row.fem_ms_per_step = 1e3 * fem_r.stepping_seconds / N;
        row.newton          = fem_r.newton_iterations;
        std::vector<double> &F_fem = row.F_fem;
        F_fem.resize(N + 1);
        for (unsigned k = 0; k <= N; ++k)
          {
            F_fem[k] = -dot(fem_r.plane_force.at("wall")[k], c.d);
            row.fem_peak_force = std::max(row.fem_peak_force, F_fem[k]);
            row.fem_max_penetration =
              std::max(row.fem_max_penetration, fem_r.plane_penetration.at("wall")[k]);
          }
        log << " " << since(t0) << " s; IRDM ...";
        // IRDM, both mappings; IRDM step n is FEM state n + 1... here the wall acts from FEM
        // step 1 on, and IRDM step n (n = 0, 1, ...) is FEM step n + 1.
        for (int mapping = 0; mapping < 2; ++mapping)
          {
            PlaneInteraction run(model, mapping == 0 ? OrientationMapping::nearest
                                                     : OrientationMapping::interpolated);
            double ef = 0, nf = 0, eu = 0, nu = 0, t_force = 0, t_surface = 0;
            double sum_irdm = 0, sum_fem = 0;
            for (unsigned k = 1; k <= N; ++k)
              {
                const auto   t1 = Clock::now();
                const double F  = run.step(c.d, wall_at(k * tau));
                row.F_irdm[mapping].push_back(F);
                t_force += since(t1);
                const auto  t2 = Clock::now();
                const auto &u  = run.update_surface();
                t_surface += since(t2);
                ef += (F - F_fem[k]) * (F - F_fem[k]);
                nf += F_fem[k] * F_fem[k];
                sum_irdm += F;
                sum_fem += F_fem[k];
                add_surface_error(u, fem_r.surface_displacement[k], eu, nu);
              }
            row.force_error[mapping]        = std::sqrt(ef / std::max(nf, 1e-300));
            row.impulse_error[mapping] = std::abs(sum_irdm - sum_fem) / std::max(sum_fem, 1e-300);
            row.displacement_error[mapping] = std::sqrt(eu / std::max(nu, 1e-300));
            if (mapping == 1)
              {
                row.irdm_force_us   = 1e6 * t_force / N;
                row.irdm_surface_us = 1e6 * t_surface / N;
              }
          }
        {
          PlaneInteraction run(model, OrientationMapping::interpolated);
          double           eu = 0, nu = 0;
          for (unsigned k = 1; k <= N; ++k)
            {
              run.apply(c.d, F_fem[k]);
              add_surface_error(run.update_surface(), fem_r.surface_displacement[k], eu, nu);
            }
          row.open_loop_displacement_error = std::sqrt(eu / std::max(nu, 1e-300));
        }
        log << " force error " << 100 * row.force_error[1] << " %, displacement error "
            << 100 * row.displacement_error[1] << " % (open loop "
            << 100 * row.open_loop_displacement_error << " %)\n";
        rows.push_back(row);
      }

    // 3. Report.
    {
      std::ostringstream csv;
      csv << "case,kind,dx,dy,dz,on_dome,depth_m,speed_m_s,fem_peak_force_N,"
             "fem_max_penetration_m,force_error_nearest,force_error_interpolated,"
             "displacement_error_nearest,displacement_error_interpolated,"
             "open_loop_displacement_error,impulse_error_nearest,impulse_error_interpolated,fem_ms_per_step,irdm_force_us_per_step,"
             "irdm_surface_us_per_step,fem_newton_iterations\n";
      for (const auto &r : rows)
        csv << r.c.name << "," << r.c.kind << "," << r.c.d[0] << "," << r.c.d[1] << ","
            << r.c.d[2] << "," << r.on_dome << "," << r.c.depth << "," << r.c.speed << ","
            << r.fem_peak_force << "," << r.fem_max_penetration << "," << r.force_error[0]
            << "," << r.force_error[1] << "," << r.displacement_error[0] << ","
            << r.displacement_error[1] << "," << r.open_loop_displacement_error << ","
            << r.impulse_error[0] << "," << r.impulse_error[1] << "," << r.fem_ms_per_step << "," << r.irdm_force_us << "," << r.irdm_surface_us << ","
            << r.newton << "\n";
      write_text_file((fs::path(dir) / "planes.csv").string(), csv.str());
    }
    {
      std::ostringstream csv;
      csv << "case,time_s,penetration_m,fem_force_N,irdm_force_nearest_N,"
             "irdm_force_interpolated_N\n";
      for (const auto &r : rows)
        for (std::size_t k = 1; k < r.F_fem.size(); ++k)
          csv << r.c.name << "," << k * tau << ","
              << interp(r.c.times, r.c.penetration, k * tau) << "," << r.F_fem[k] << ","
              << r.F_irdm[0][k - 1] << "," << r.F_irdm[1][k - 1] << "\n";
      write_text_file((fs::path(dir) / "forces.csv").string(), csv.str());
    }
    std::ostringstream md;
    md.precision(3);
    md << "# Plane contact by virtual DOFs against the nonlinear FEM\n\n"
       << "Generated by `irdm validate-planes`. Body: `" << o.scene << "` (probes ignored, gravity "
       << "off), nonlinear FEM (neo-Hookean, penalty plane contact) as ground truth. Virtual-DOF "
       << "model: " << model.n_orientations << " orientations (icosahedron subdivided "
       << o.subdivisions << " times), T = " << model.length << " samples of " << tau * 1e3
       << " ms, " << model.n_surface << " surface vertices; mean FEM time per orientation "
       << per_orientation << " s (one core).\n\n"
       << "The wall moves along -d toward the cat; its penetration p(t) into the undeformed body "
       << "(its free vertices; the fixed base belongs to the ground) is prescribed (press: in "
       << "over 0.2 s, held to 0.35 s, out by 0.45 s; impact: in and out at the given speed to "
       << "2 mm). Errors are relative L2 over the whole history: force "
       << "||F_IRDM - F_FEM|| / ||F_FEM||, surface displacement over all surface vertices and "
       << "steps; impulse: |sum F_IRDM - sum F_FEM| / sum F_FEM (the momentum the wall gives, "
       << "insensitive to when a bouncing contact fires). `near` maps the wall to the nearest virtual DOF, `interp` interpolates "
       << "between the three around it. `open loop`: the IRDM surface driven by the FEM's own "
       << "wall force (interpolated mapping), the responses' error without the contact solve's. "
       << "Directions: side " << vec_text(side) << ", top " << vec_text(top) << " (both dome "
       << "directions), oblique " << vec_text(oblique) << " (the centre of a dome triangle next "
       << "to the side whose virtual DOFs first touch different body parts), between "
       << vec_text(between) << " (the centre of a dome triangle whose virtual DOFs and centre "
       << "all first touch the same vertex). "
       << "FEM pen.: the deepest penetration of the FEM's penalty wall into the free surface, "
       << "which should be small against p.\n\n"
       << "| case | FEM peak force (N) | FEM pen. (mm) | force err near | force err interp | "
          "impulse err near | impulse err interp | displ. err near | displ. err interp | "
          "displ. err open loop | FEM ms/step | IRDM force us/step | IRDM surface us/step |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto &r : rows)
      md << "| " << r.c.name << " | " << r.fem_peak_force << " | "
         << 1e3 * r.fem_max_penetration << " | " << 100 * r.force_error[0] << " % | "
         << 100 * r.force_error[1] << " % | " << 100 * r.impulse_error[0] << " % | "
         << 100 * r.impulse_error[1] << " % | " << 100 * r.displacement_error[0] << " % | "
         << 100 * r.displacement_error[1] << " % | " << 100 * r.open_loop_displacement_error
         << " % | " << r.fem_ms_per_step << " | " << r.irdm_force_us << " | "
         << r.irdm_surface_us << " |\n";
    md << "\n![error against depth and speed](planes.png)\n";
    write_text_file((fs::path(dir) / "planes.md").string(), md.str());
    if (!o.plot_script.empty())
      {
        const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "warning: the chart script failed: " << cmd << "\n";
      }
    log << "report: " << dir << "/planes.md\n";
  }
} // namespace irdm::validation
