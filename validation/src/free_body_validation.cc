// The free body against the nonlinear FEM (validation/free_body_validation.h).
#include <irdm/free_body.h>
#include <irdm/modal_model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>
#include <validation/free_body_validation.h>

#include "scene_runs.h"

#include <Eigen/Dense>
#include <Eigen/SVD>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    Eigen::Vector3d
    vec(const Vec3 &a)
    {
      return {a[0], a[1], a[2]};
    }
    Vec3
    arr(const Eigen::Vector3d &v)
    {
      return {v(0), v(1), v(2)};
    }

    // One case: the floor's normal (world = the mesh's frame; gravity is -9.81 along it), the
    // drop height (gap between the body's lowest point and the floor), the initial velocity
    // and spin, and an optional wall along +x.
    struct Case
    {
      std::string     name;
      Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
      double          height = 0.02;
      Eigen::Vector3d velocity = Eigen::Vector3d::Zero(), spin = Eigen::Vector3d::Zero();
      bool            wall = false;
    };

    std::vector<Case>
    cases(const bool quick)
    {
      const Eigen::Vector3d tilted =
        Eigen::AngleAxisd(25 * M_PI / 180, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitZ();
      std::vector<Case> c;
      if (!quick)
        c.push_back({"drop_2cm", Eigen::Vector3d::UnitZ(), 0.02});
      c.push_back({"drop_5cm", Eigen::Vector3d::UnitZ(), 0.05});
      if (!quick)
        {
          c.push_back({"drop_10cm", Eigen::Vector3d::UnitZ(), 0.10});
          c.push_back({"spin_roll", Eigen::Vector3d::UnitZ(), 0.02, Eigen::Vector3d::Zero(),
                       Eigen::Vector3d(0, 8, 0)});
          c.push_back({"wall_throw", Eigen::Vector3d::UnitZ(), 0.005, Eigen::Vector3d(0.6, 0, 0),
                       Eigen::Vector3d::Zero(), true});
        }
      c.push_back({"tilted_5cm", tilted, 0.05});
      return c;
    }

    // Rotation best fitting the points q to p (both centred), uniform weights (Kabsch): the
    // surface's orientation, measured the same way on both methods.
    Eigen::Matrix3d
    best_rotation(const std::vector<Eigen::Vector3d> &p, const std::vector<Eigen::Vector3d> &q)
    {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      for (size_t i = 0; i < p.size(); ++i)
        H += p[i] * q[i].transpose();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      D(2, 2)           = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
      return svd.matrixV() * D * svd.matrixU().transpose();
    }

    // A deformed surface split into its fitted rigid pose and the deformation in that frame.
    struct Fit
    {
      Eigen::Matrix3d              R;
      std::vector<Eigen::Vector3d> deformation; // R^T (x - centroid) - (X - rest centroid)
    };

    Fit
    fit(const std::vector<Eigen::Vector3d> &rest, const std::vector<Eigen::Vector3d> &x)
    {
      Eigen::Vector3d c = Eigen::Vector3d::Zero(), c0 = Eigen::Vector3d::Zero();
      for (size_t i = 0; i < x.size(); ++i)
        c += x[i] / x.size(), c0 += rest[i] / x.size();
      std::vector<Eigen::Vector3d> p(x.size()), q(x.size());
      for (size_t i = 0; i < x.size(); ++i)
        p[i] = rest[i] - c0, q[i] = x[i] - c;
      Fit f;
      f.R = best_rotation(p, q);
      f.deformation.resize(x.size());
      for (size_t i = 0; i < x.size(); ++i)
        f.deformation[i] = f.R.transpose() * q[i] - p[i];
      return f;
    }

    double
    angle_deg(const Eigen::Matrix3d &R)
    {
      return Eigen::AngleAxisd(R).angle() * 180 / M_PI;
    }

    struct Row
    {
      std::string c;
      double      E = 0;
      double      com_error = 0, angle_error = 0, force_error = 0, impulse_error = 0,
             deformation_error = 0, irdm_us = 0, fem_ms = 0, peak_ratio = 0, rotation_deg = 0,
             distance = 0, centrifugal = 0, energy_growth = 0;
      bool        stable = true;
      std::string fem_failed; // the FEM's error message when it could not run the case
    };

    std::string
    material_name(const double E)
    {
      std::ostringstream s;
      s << E / 1000 << "kPa";
      return s.str();
    }
  } // namespace

  void
  run_free_body_validation(const FreeBodyValidationOptions &o, std::ostream &log)
  {
    const std::string base_text = [&] {
      std::ifstream in(o.scene);
      if (!in)
        throw InputError("validate-free: cannot read the scene '" + o.scene + "'");
      std::stringstream s;
      s << in.rdbuf();
      return s.str();
    }();
    const std::string base_dir = fs::path(o.scene).parent_path().string();
    const fem::Scene base = fem::parse_scene(base_text, base_dir, o.scene);
    if (!base.fixed_surfaces.empty())
      throw InputError("validate-free: the scene '" + o.scene + "' fixes a surface; the "
                       "free-body validation needs a body fixed to nothing");
    if (!(o.duration > 0))
      throw InputError("validate-free: the duration must be positive");
    const std::string dir = (fs::path(o.report_dir) / "free").string();
    fs::create_directories(dir);
    fs::create_directories(o.model_dir);
    // Two runs never write the same report or models at once.
    const OutputLock report_lock((fs::path(dir) / "free.csv").string());
    const OutputLock models_lock((fs::path(o.model_dir) / "free_cat").string());

    std::vector<Row> rows;
    std::ostringstream series;
    series << "case,material,time_s,fem_force_N,irdm_force_N,fem_com_z_m,irdm_com_z_m,"
              "fem_angle_deg,irdm_angle_deg\n";
    for (const double E : o.materials)
      {
        // The body in this material: the scene's text with its modulus replaced, so that the
        // model records the scene it was made from.
        std::ostringstream e;
        e << "\"youngs_modulus_Pa\": " << E;
        std::string  text = base_text;
        const size_t key  = text.find("\"youngs_modulus_Pa\"");
        if (key == std::string::npos)
          throw InputError("validate-free: the scene '" + o.scene + "' gives no youngs_modulus_Pa");
        const size_t colon = text.find(':', key), end = text.find_first_of(",}", colon);
        text.replace(key, end - key, e.str());
        const fem::Scene body = fem::parse_scene(text, base_dir, o.scene);
        const double     tau  = body.time_step;

        // Route 2: the free-body model (the six rigid modes removed, every elastic mode kept).
        fem::PrecomputeOptions po;
        po.output  = (fs::path(o.model_dir) / ("free_cat_" + material_name(E) + ".h5")).string();
        po.restart = true;
        log << "validate-free: E = " << E << " Pa: precomputing the free model " << po.output
            << std::endl;
        fem::precompute_impulse_responses(body, po);
        const ImpulseResponseModel model = load_model(po.output, tau);
        ModalModelOptions          mo;
        mo.surface_modes = std::min(o.surface_modes, model.modes.n_modes);
        const ModalModel modal = make_modal_model(model, mo);
        const double     area  = mean_free_vertex_area(model);
        std::vector<Eigen::Vector3d> rest(model.n_outputs / 3);
        for (size_t v = 0; v < rest.size(); ++v)
          rest[v] = vec(model.output_coordinates[v]);
        const Eigen::Vector3d c0 = vec(model.center_of_mass);

        for (const Case &k : cases(o.quick))
          {
            log << "validate-free: " << k.name << ", E = " << E << " Pa" << std::endl;
            // The planes: the floor below the body's lowest point along `up`, and a wall.
            double lowest = 1e300, farthest_x = -1e300;
            for (const auto &X : rest)
              lowest = std::min(lowest, k.up.dot(X)), farthest_x = std::max(farthest_x, X(0));
            std::vector<fem::RigidPlane> planes(1);
            planes[0].name     = "floor";
            planes[0].normal   = arr(k.up);
            planes[0].position = fem::History::constant(arr((lowest - k.height) * k.up));
            if (k.wall)
              {
                fem::RigidPlane w;
                w.name     = "wall";
                w.normal   = {-1, 0, 0};
                w.position = fem::History::constant({farthest_x + 0.02, 0, 0});
                planes.push_back(w);
              }
            fem::Scene s               = body;
            s.kinematics               = fem::Kinematics::nonlinear;
            s.gravity_enabled          = true;
            s.gravity                  = arr(-9.81 * k.up);
            s.initial_velocity         = arr(k.velocity);
            s.initial_angular_velocity = arr(k.spin);
            s.planes                   = planes;
            s.duration                 = o.duration;
            s.outputs                  = fem::Scene::Outputs();
            s.outputs.hdf5 = s.outputs.csv = false;
            s.outputs.surface                = true;
            const auto     t_fem = Clock::now();
            fem::RunResult fem_r;
            try
              {
                fem_r = fem::NonlinearElasticity(s).run();
              }
            catch (const std::exception &e)
              {
                // The truth itself failed (Newton at a large, fast deformation): nothing to
                // compare this case with; say so in the report.
                log << "  the FEM failed: " << e.what() << std::endl;
                Row row;
                row.c = k.name, row.E = E, row.fem_failed = e.what();
                rows.push_back(row);
                continue;
              }
            const double fem_seconds = std::chrono::duration<double>(Clock::now() - t_fem).count();
            const unsigned n = s.n_steps();
            std::map<long long, unsigned> at;
            for (unsigned i = 0; i < fem_r.surface.node_tags.size(); ++i)
              at[fem_r.surface.node_tags[i]] = i;

            // The runtime, with the FEM's penalty as a per-vertex stiffness.
            FreeBodyOptions fo;
            fo.gravity = -9.81 * k.up;
            FreeBodyInteraction irdm(modal, fo);
            irdm.rigid().set_velocity(k.velocity, k.spin);
            std::vector<PlaneTarget> targets(planes.size());
            for (size_t p = 0; p < planes.size(); ++p)
              {
                targets[p].normal    = planes[p].normal;
                targets[p].point     = planes[p].position.at(0);
                targets[p].stiffness = fem_r.plane_penalty.at(planes[p].name) * area;
              }
            const double mass = model.mass;
            const auto   energy = [&] {
              return irdm.energy() - mass * fo.gravity.dot(irdm.rigid().state().position);
            };
            const double energy0 = energy();
            double       r_gyration = std::sqrt(0.5 * (model.inertia[0][0] + model.inertia[1][1] +
                                                       model.inertia[2][2]) / mass);

            Row row;
            row.c = k.name, row.E = E;
            row.fem_ms = 1e3 * fem_seconds / n;
            std::vector<double>          x(model.n_outputs);
            std::vector<Eigen::Vector3d> xf(rest.size()), xi(rest.size());
            double f2 = 0, df2 = 0, peak_f = 0, peak_i = 0, d2 = 0, dd2 = 0, step_seconds = 0,
                   centrifugal = 0, peak_contact = mass * 9.81;
            Eigen::Vector3d J_f = Eigen::Vector3d::Zero(), J_i = Eigen::Vector3d::Zero(),
                            c_prev = c0;
            for (unsigned step = 1; step <= n; ++step)
              {
                const auto t0 = Clock::now();
                const bool ok = irdm.step(targets.data(), static_cast<int>(targets.size()));
                step_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
                row.stable = row.stable && ok;
                irdm.surface_positions(x.data());
                Eigen::Vector3d F_f = Eigen::Vector3d::Zero(), F_i = Eigen::Vector3d::Zero();
                for (size_t p = 0; p < planes.size(); ++p)
                  {
                    F_f += vec(fem_r.plane_force.at(planes[p].name)[step]);
                    F_i += irdm.plane_force(static_cast<int>(p));
                  }
                f2 += F_f.squaredNorm(), df2 += (F_f - F_i).squaredNorm();
                J_f += tau * F_f, J_i += tau * F_i;
                peak_f = std::max(peak_f, F_f.norm()), peak_i = std::max(peak_i, F_i.norm());
                peak_contact = std::max(peak_contact, F_f.norm());
                const Eigen::Vector3d c_f = c0 + vec(fem_r.center_of_mass_displacement[step]);
                const Eigen::Vector3d c_i = irdm.rigid().state().position;
                row.distance += (c_f - c_prev).norm();
                c_prev        = c_f;
                row.com_error = std::max(row.com_error, (c_f - c_i).norm());
                for (size_t v = 0; v < rest.size(); ++v)
                  {
                    const unsigned j = at.at(model.output_node_tags[v]);
                    for (int d = 0; d < 3; ++d)
                      xf[v](d) = rest[v](d) + fem_r.surface_displacement[step][3 * j + d];
                    xi[v] = Eigen::Vector3d(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
                    row.stable = row.stable && xi[v].allFinite();
                  }
                const Fit ff = fit(rest, xf), fi = fit(rest, xi);
                row.angle_error  = std::max(row.angle_error, angle_deg(fi.R * ff.R.transpose()));
                row.rotation_deg = std::max(row.rotation_deg, angle_deg(ff.R));
                for (size_t v = 0; v < rest.size(); ++v)
                  d2 += ff.deformation[v].squaredNorm(),
                    dd2 += (ff.deformation[v] - fi.deformation[v]).squaredNorm();
                const double w = irdm.rigid().angular_velocity().norm();
                centrifugal    = std::max(centrifugal, mass * w * w * r_gyration);
                row.energy_growth = std::max(row.energy_growth, (energy() - energy0) / std::abs(energy0));
                series << k.name << ',' << material_name(E) << ',' << step * tau << ','
                       << F_f.dot(k.up) << ',' << F_i.dot(k.up) << ',' << c_f(2) << ',' << c_i(2)
                       << ',' << angle_deg(ff.R) << ',' << angle_deg(fi.R) << '\n';
              }
            row.com_error /= std::max(row.distance, 1e-12);
            row.force_error       = std::sqrt(df2 / std::max(f2, 1e-300));
            row.impulse_error     = (J_i - J_f).norm() / std::max(J_f.norm(), 1e-300);
            row.deformation_error = std::sqrt(dd2 / std::max(d2, 1e-300));
            row.peak_ratio        = peak_i / std::max(peak_f, 1e-300);
            row.irdm_us           = 1e6 * step_seconds / n;
            row.centrifugal       = centrifugal / peak_contact;
            row.stable            = row.stable && row.energy_growth < 0.05;
            log << "  com " << row.com_error << ", angle " << row.angle_error << " deg, force "
                << row.force_error << ", impulse " << row.impulse_error << ", deformation "
                << row.deformation_error << ", IRDM " << row.irdm_us << " us/step, FEM "
                << row.fem_ms << " ms/step" << std::endl;
            rows.push_back(row);
          }
      }

    std::ostringstream csv;
    csv << "case,material,method,com_error,angle_error_deg,force_error,impulse_error,"
           "deformation_error,irdm_us_per_step,fem_ms_per_step,stable\n";
    for (const Row &r : rows)
      {
        if (!r.fem_failed.empty())
          {
            csv << r.c << ',' << material_name(r.E) << ",modal,nan,nan,nan,nan,nan,nan,nan,fem_failed\n";
            continue;
          }
        csv << r.c << ',' << material_name(r.E) << ",modal," << r.com_error << ',' << r.angle_error
            << ',' << r.force_error << ',' << r.impulse_error << ',' << r.deformation_error << ','
            << r.irdm_us << ',' << r.fem_ms << ',' << (r.stable ? "yes" : "no") << '\n';
      }
    write_text_file((fs::path(dir) / "free.csv").string(), csv.str());
    write_text_file((fs::path(dir) / "series.csv").string(), series.str());

    std::ostringstream md;
    md << "# Free body against the nonlinear FEM (issue 14, first part)\n\n"
       << "Written by `irdm validate-free" << (o.quick ? " --quick" : "") << "`. Body: `" << o.scene
       << "` (the cat, P1, fixed to nothing), Newmark average acceleration, tau = "
       << base.time_step * 1e3 << " ms, " << o.duration
       << " s per case, gravity 9.81 m/s^2 against the floor's normal. Truth: the nonlinear FEM on "
          "the same mesh (neo-Hookean, penalty planes, default penalty 100 E / h). IRDM: "
          "`FreeBodyInteraction` (rigid body + the modal deformation of the free-body model, "
          "route 2, every elastic mode in the force loop, "
       << o.surface_modes << " in the surface), many-vertex contact with the FEM penalty's "
          "per-vertex equivalent as the plane stiffness. Method and discretization are not "
          "separated here: the FEM and the model share the P1 mesh, so every error below is the "
          "method's (linear elasticity in the body frame against neo-Hookean, vertex against "
          "face-integrated contact), not the mesh's.\n\n"
       << "Errors: centre of mass, the largest distance between the two paths over the run, "
          "relative to the distance the FEM's centre travelled; orientation, the largest angle "
          "between the two surfaces' best-fit rotations (Kabsch, uniform weights over the "
          "surface vertices, the same estimator on both); plane force, relative L2 of the total "
          "plane force over the run, and the total impulse's relative error; deformation, "
          "relative RMS of the surface in its best-fit frame. Stable: every step solved, finite, "
          "and the runtime's energy (rigid, elastic, gravity) never above its start by 5 %.\n\n"
       << "| case | material | com | angle (deg) | force | impulse | peak IRDM/FEM | deformation "
          "| FEM rotation (deg) | centrifugal / contact | IRDM us/step | FEM ms/step | stable |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Row &r : rows)
      if (!r.fem_failed.empty())
        md << "| " << r.c << " | " << material_name(r.E) << " | the FEM failed: " << r.fem_failed
           << " |||||||||||\n";
      else
        md << "| " << r.c << " | " << material_name(r.E) << " | " << r.com_error << " | "
           << r.angle_error << " | " << r.force_error << " | " << r.impulse_error << " | "
           << r.peak_ratio << " | " << r.deformation_error << " | " << r.rotation_deg << " | "
           << r.centrifugal << " | " << r.irdm_us << " | " << r.fem_ms << " | "
           << (r.stable ? "yes" : "no") << " |\n";
    md << "\n\"centrifugal / contact\": the largest centrifugal load of the body's spin (m w^2 "
          "times its radius of gyration) over the largest plane force (at least its weight): "
          "the size of what the runtime leaves out of the deformation (irdm/free_body.h).\n\n"
          "Not yet here (issue 14 continues): route 1 (recorded response minus the best rigid "
          "fit) beside route 2, the free-flight and 60 s checks in this report (they are tests: "
          "`FreeBodyRuntime.*`), the Fig. 6 chart and frames.\n";
    write_text_file((fs::path(dir) / "report.md").string(), md.str());
    log << "validate-free: wrote " << dir << "/free.csv, series.csv, report.md" << std::endl;
  }
} // namespace irdm::validation
