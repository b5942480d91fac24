// Reference-FEM verification against theory. Each check builds its scene in code (so the
// report states exactly what ran), runs the FEM, and compares with an analytic or exact value.
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_template.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <validation/fem_verification.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace irdm::validation
{
  namespace fs = std::filesystem;
  using fem::ElasticDynamics;
  using fem::RunResult;
  using fem::Scene;

  namespace
  {
    std::string
    fmt(const char *format, const double v)
    {
      char buf[64];
      std::snprintf(buf, sizeof buf, format, v);
      return buf;
    }

    double
    seconds_since(const std::chrono::steady_clock::time_point t0)
    {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

    // The cat with its base fixed, the soft material of the seed papers (E = 2 kPa was the
    // seed's value; nu and rho from seed 001).
    std::string
    cat_scene_json(const std::string &mesh, const unsigned degree, const std::string &extra,
                   const double youngs_modulus = 2000)
    {
      return R"({"format": "irdm-scene/1", "name": "cat", "mesh": {"file": ")" + mesh +
             R"("}, "fe_degree": )" + std::to_string(degree) +
             R"(, "material": {"youngs_modulus_Pa": )" + fmt("%.17g", youngs_modulus) +
             R"(, "poisson_ratio": 0.4, "density_kg_m3": 1100}, "fixed_surfaces": ["base"])" +
             extra + "}";
    }

    Scene
    scene_from(const std::string &json)
    {
      return fem::parse_scene(json, ".", "verification scene");
    }

    double
    total_energy(const RunResult &r, const std::size_t k)
    {
      return r.kinetic_energy[k] + r.strain_energy[k];
    }
  } // namespace

  double
  BeamModel::euler_bernoulli_frequency() const
  {
    const double beta_l = 1.8751040687119611; // first root of 1 + cos x cosh x = 0
    const double I = std::pow(side, 4) / 12, A = side * side;
    return beta_l * beta_l / (2 * M_PI * length * length) *
           std::sqrt(youngs_modulus * I / (density * A));
  }

  double
  BeamModel::tip_deflection(const double force) const
  {
    const double I = std::pow(side, 4) / 12;
    return force * std::pow(length, 3) / (3 * youngs_modulus * I);
  }

  std::string
  beam_scene_json(const std::string &mesh_file, const unsigned degree, const BeamModel &beam,
                  const std::string &extra_keys)
  {
    std::ostringstream s;
    s.precision(17);
    s << R"({"format": "irdm-scene/1", "name": "beam", "mesh": {"file": ")" << mesh_file
      << R"("}, "fe_degree": )" << degree << R"(, "material": {"youngs_modulus_Pa": )"
      << beam.youngs_modulus << R"(, "poisson_ratio": )" << beam.poisson_ratio
      << R"(, "density_kg_m3": )" << beam.density << R"(}, "fixed_surfaces": ["clamp"])"
      << extra_keys << "}";
    return s.str();
  }

  double
  HertzBall::mass() const
  {
    return body_mass > 0 ? body_mass : density * 4.0 / 3.0 * M_PI * std::pow(radius, 3);
  }

  double
  HertzBall::effective_modulus() const
  {
    return youngs_modulus / (1 - poisson_ratio * poisson_ratio);
  }

  double
  HertzBall::contact_stiffness() const
  {
    return 4.0 / 3.0 * effective_modulus() * std::sqrt(radius);
  }

  double
  HertzBall::max_indentation(const double v) const
  {
    return std::pow(15 * mass() * v * v / (16 * effective_modulus() * std::sqrt(radius)), 0.4);
  }

  double
  HertzBall::peak_force(const double v) const
  {
    return contact_stiffness() * std::pow(max_indentation(v), 1.5);
  }

  double
  HertzBall::contact_time(const double v) const
  {
    const double Es = effective_modulus();
    return 2.87 * std::pow(mass() * mass() / (radius * Es * Es * v), 0.2);
  }

  double
  HertzBall::contact_radius(const double v) const
  {
    return std::sqrt(radius * max_indentation(v));
  }

  double
  HertzBall::centre_compliance() const
  {
    const double mu = youngs_modulus / (2 * (1 + poisson_ratio));
    return (3 - 2 * poisson_ratio) / (4 * M_PI * mu * radius);
  }

  double
  HertzBall::peak_force_finite_ball(const double v) const
  {
    // Root of g(F) = 2/5 k^(-2/3) F^(5/3) - c F^2 / 2 - 1/2 m v^2 on (0, F*), F* the maximum
    // of the work term (g rises there from -1/2 m v^2); bisection, as g is monotone on it.
    const double k = contact_stiffness(), c = centre_compliance(), energy = 0.5 * mass() * v * v;
    const auto   g = [&](const double F) {
      return 0.4 * std::pow(k, -2.0 / 3.0) * std::pow(F, 5.0 / 3.0) - 0.5 * c * F * F - energy;
    };
    double lo = 0, hi = 8 / (27 * k * k * c * c * c); // F*: dW/dF = 0
    if (g(hi) < 0)
      return std::nan(""); // the ball is too compliant for the estimate to hold
    for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i)
      (g(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
  }

  std::string
  ball_scene_json(const std::string &mesh_file, const HertzBall &ball, const double speed,
                  const double time_step, const double duration, const double penalty)
  {
    std::ostringstream s;
    s.precision(17);
    s << R"({"format": "irdm-scene/1", "name": "ball", "mesh": {"file": ")" << mesh_file
      << R"("}, "fe_degree": 1, "material": {"youngs_modulus_Pa": )" << ball.youngs_modulus
      << R"(, "poisson_ratio": )" << ball.poisson_ratio << R"(, "density_kg_m3": )"
      << ball.density << R"(}, "integrator": {"type": "newmark"}, "time": {"step_s": )"
      << time_step << R"(, "duration_s": )" << duration
      << R"(}, "kinematics": "nonlinear", "initial_velocity_m_s": [0, 0, )" << -speed
      << R"(], "planes": [{"name": "floor", "normal": [0, 0, 1], "position": {"times_s": [0], )"
      << R"("points_m": [[0, 0, -1e-4]]})";
    if (penalty > 0)
      s << R"(, "penalty_Pa_m": )" << penalty;
    s << "}]}";
    return s.str();
  }

  namespace
  {
    struct Report
    {
      std::vector<CheckResult> checks;
      TemplateValues           values; // of validation/templates/verify_fem.md
      std::string              dir;
      std::ostream            &log;

      void
      add(const CheckResult &c)
      {
        checks.push_back(c);
        log << (c.pass ? "  PASS  " : "  FAIL  ") << c.name << ": " << c.measured << " ("
            << c.criterion << ")\n";
      }
      std::string
      path(const std::string &file) const
      {
        return (fs::path(dir) / file).string();
      }
    };

    // 1 and 2: cantilever frequency (with convergence) and static tip deflection.
    void
    check_beam(const FemVerificationOptions &o, Report &rep)
    {
      const BeamModel beam;
      const double    f_eb = beam.euler_bernoulli_frequency();
      std::vector<unsigned> divisions = {2, 4, 8};
      if (o.quick)
        divisions.pop_back();
      std::vector<double> n_col, dofs_col, f_col, err_col, tip_col, tip_err_col, time_col;
      const double force = 1e-4; // N, on the tip face: deflection/length ~ 1 %
      const double tip_eb = beam.tip_deflection(force);
      rep.log << "beam: Euler-Bernoulli f1 = " << f_eb << " Hz, tip deflection " << tip_eb
              << " m\n";
      for (const unsigned n : divisions)
        {
          const auto t0 = std::chrono::steady_clock::now();
          const std::string mesh = (fs::path(o.mesh_dir) / ("beam_" + std::to_string(n) + ".msh")).string();
          std::ostringstream extra;
          extra.precision(17);
          extra << R"(, "time": {"step_s": 1, "duration_s": 1},
                 "loads": [{"type": "surface_force", "surface": "tip", "total_force_N": [0, 0, )"
                << -force << R"(]}],
                 "outputs": {"vertices": [{"name": "tip", "vertex": {"nearest_to_m": [)"
                << beam.length << ", " << beam.side / 2 << ", " << beam.side / 2 << "]}}]}";
          ElasticDynamics fem(scene_from(beam_scene_json(mesh, 2, beam, extra.str())));
          const double f1  = fem.natural_frequencies(2)[0];
          const double tip = -fem.solve_static(0).vertex_displacement.at("tip")[0][2];
          n_col.push_back(n);
          dofs_col.push_back(fem.n_dofs());
          f_col.push_back(f1);
          err_col.push_back(f1 / f_eb - 1);
          tip_col.push_back(tip);
          tip_err_col.push_back(tip / tip_eb - 1);
          time_col.push_back(seconds_since(t0));
          rep.log << "  beam_" << n << " P2: " << fem.n_dofs() << " DoFs, f1 = " << f1
                  << " Hz, tip = " << tip << " m (" << time_col.back() << " s)\n";
        }
      write_csv(rep.path("beam_convergence.csv"),
                {"elements_across", "n_dofs", "f1_Hz", "f1_rel_error_vs_euler_bernoulli",
                 "tip_deflection_m", "tip_rel_error_vs_beam_theory", "seconds"},
                {n_col, dofs_col, f_col, err_col, tip_col, tip_err_col, time_col});
      std::string rate = "n/a (needs three meshes; --quick ran two)";
      if (f_col.size() == 3)
        rate = fmt("%.2f", std::log2((f_col[0] - f_col[1]) / (f_col[1] - f_col[2])));
      std::string tip_rate = "n/a";
      if (tip_col.size() == 3)
        tip_rate = fmt("%.2f", std::log2((tip_col[1] - tip_col[0]) / (tip_col[2] - tip_col[1])));

      std::string rows;
      for (std::size_t i = 0; i < f_col.size(); ++i)
        rows += "| " + plain(n_col[i]) + " | " + plain(dofs_col[i]) + " | " + fmt("%.6g", f_col[i]) +
                " | " + fmt("%+.3f %%", 100 * err_col[i]) + " | " + fmt("%.6g", tip_col[i]) + " | " +
                fmt("%+.3f %%", 100 * tip_err_col[i]) + " | " + fmt("%.1f", time_col[i]) + " |\n";
      rep.values.insert({{"beam_length", plain(beam.length)},
                         {"beam_side", plain(beam.side)},
                         {"beam_aspect", plain(beam.length / beam.side)},
                         {"beam_youngs", plain(beam.youngs_modulus)},
                         {"beam_nu", plain(beam.poisson_ratio)},
                         {"beam_rho", plain(beam.density)},
                         {"f_eb", fmt("%.6g", f_eb)},
                         {"tip_force", plain(force)},
                         {"tip_eb", fmt("%.6g", tip_eb)},
                         {"beam_rows", rows},
                         {"f_rate", rate},
                         {"tip_rate", tip_rate}});
      rep.add({"beam f1 vs Euler-Bernoulli (finest P2)",
               fmt("%+.3f %%", 100 * err_col.back()), "|error| <= 2 %",
               std::abs(err_col.back()) <= 0.02});
      rep.add({"beam f1 converges under refinement", "rate " + rate,
               "successive differences shrink",
               f_col.size() < 3 ||
                 std::abs(f_col[1] - f_col[2]) < std::abs(f_col[0] - f_col[1])});
      rep.add({"beam static tip deflection vs beam theory (finest P2)",
               fmt("%+.3f %%", 100 * tip_err_col.back()), "|error| <= 2 %",
               std::abs(tip_err_col.back()) <= 0.02});
    }

    // The cat pushed on the head for 0.05 s, then free for at least min_free_steps and at
    // least 6 periods of its first mode (f1, Hz, returned).
    RunResult
    run_tapped_cat(const FemVerificationOptions &o, const std::string &integrator,
                   const unsigned min_free_steps, double youngs_modulus, double &release_time,
                   double &f1, unsigned &n_free_steps)
    {
      const double dt = 0.002;
      release_time    = 0.05;
      const std::string mesh = (fs::path(o.mesh_dir) / "cat.msh").string();
      {
        ElasticDynamics modes(scene_from(cat_scene_json(
          mesh, 1, R"(, "time": {"step_s": 1, "duration_s": 1})", youngs_modulus)));
        f1 = modes.natural_frequencies(1)[0];
      }
      n_free_steps = std::max<unsigned>(min_free_steps, std::ceil(6 / (f1 * dt)));
      std::ostringstream extra;
      extra << R"(, "integrator": )" << integrator << R"(, "time": {"step_s": )" << dt
            << R"(, "duration_s": )" << release_time + n_free_steps * dt << R"(},
             "loads": [{"type": "vertex_force", "vertex": {"nearest_to_m": [0.03, 0, 0.19]},
                        "force_N": [0.05, 0.02, -0.1],
                        "history": {"times_s": [0, 0.04, 0.05], "factors": [0, 1, 0]}}])";
      ElasticDynamics fem(scene_from(cat_scene_json(mesh, 1, extra.str(), youngs_modulus)));
      return fem.run();
    }

    void
    check_energy(const FemVerificationOptions &o, Report &rep)
    {
      // E = 20 kPa, the stiff end of the project's range, so that six periods of the first
      // mode take a few thousand steps.
      const double youngs_modulus = 2.0e4;
      double       t_release, f1;
      unsigned     n_free;
      const RunResult nm = run_tapped_cat(o, R"({"type": "newmark"})", 1000, youngs_modulus,
                                          t_release, f1, n_free);
      const RunResult ga =
        run_tapped_cat(o, R"({"type": "generalized_alpha", "rho_inf": 0.8})", 1000,
                       youngs_modulus, t_release, f1, n_free);
      const std::size_t k0 = nm.time.size() - 1 - n_free; // first sample after release
      const double e0 = total_energy(nm, k0);
      double drift = 0;
      for (std::size_t k = k0; k < nm.time.size(); ++k)
        drift = std::max(drift, std::abs(total_energy(nm, k) - e0) / e0);

      // Generalized-alpha: step by step, and as the mean over each period of mode 1.
      const double g0 = total_energy(ga, k0);
      double worst_step = -1e300;
      for (std::size_t k = k0 + 1; k < ga.time.size(); ++k)
        worst_step = std::max(worst_step, (total_energy(ga, k) - total_energy(ga, k - 1)) / g0);
      const double dt = ga.time[1] - ga.time[0];
      const std::size_t window = static_cast<std::size_t>(std::lround(1 / (f1 * dt)));
      std::vector<double> means;
      for (std::size_t start = k0; start + window <= ga.time.size(); start += window)
        {
          double sum = 0;
          for (std::size_t k = start; k < start + window; ++k)
            sum += total_energy(ga, k);
          means.push_back(sum / window);
        }
      double worst_window = -1e300;
      for (std::size_t i = 1; i < means.size(); ++i)
        worst_window = std::max(worst_window, (means[i] - means[i - 1]) / means[0]);
      const double ga_final = total_energy(ga, ga.time.size() - 1) / g0;

      std::vector<double> e_nm, e_ga;
      for (std::size_t k = 0; k < nm.time.size(); ++k)
        {
          e_nm.push_back(total_energy(nm, k));
          e_ga.push_back(total_energy(ga, k));
        }
      write_csv(rep.path("energy.csv"),
                {"time_s", "newmark_energy_J", "generalized_alpha_0.8_energy_J"},
                {nm.time, e_nm, e_ga});
      rep.values.insert({{"t_release", plain(t_release)},
                         {"n_free", plain(n_free)},
                         {"drift", fmt("%.3e", drift)},
                         {"f1", fmt("%.4g", f1)},
                         {"window", plain(static_cast<double>(window))},
                         {"worst_window", fmt("%.3e", worst_window)},
                         {"n_periods", plain(static_cast<double>(means.size()))},
                         {"ga_final", fmt("%.4f", ga_final)},
                         {"worst_step", fmt("%.3e", worst_step)}});
      rep.add({"Newmark energy conservation, " + std::to_string(n_free) + " free steps",
               fmt("%.3e", drift) + " relative",
               "<= 1e-9", drift <= 1e-9});
      rep.add({"generalized-alpha (0.8) dissipates monotonically, per period of mode 1",
               "largest rise " + fmt("%.3e", worst_window) + " (per step: " +
                 fmt("%+.1e", worst_step) + ")",
               "every period's mean below the last (>= 3 periods)",
               means.size() >= 3 && worst_window < 0 && ga_final < 1});
    }

    void
    check_gravity(const FemVerificationOptions &o, Report &rep)
    {
      const std::string extra = R"(, "time": {"step_s": 1, "duration_s": 1},
                                   "gravity": {"enabled": true, "acceleration_m_s2": [0, 0, -9.81]})";
      ElasticDynamics fem(
        scene_from(cat_scene_json((fs::path(o.mesh_dir) / "cat.msh").string(), 2, extra)));
      const auto   r      = fem.solve_static(0);
      const auto   R      = r.fixed_reaction.at("base")[0];
      const double weight = 1100 * 9.81 * fem.volume();
      const double err    = std::abs(R[2] - weight) / weight;
      rep.values.insert({{"cat_dofs", plain(fem.n_dofs())},
                         {"volume", fmt("%.9g", fem.volume())},
                         {"weight", fmt("%.12g", weight)},
                         {"reaction_x", fmt("%.3e", R[0])},
                         {"reaction_y", fmt("%.3e", R[1])},
                         {"reaction_z", fmt("%.12g", R[2])},
                         {"gravity_error", fmt("%.2e", err)}});
      rep.add({"base reaction = rho g V", fmt("%.2e", err) + " relative", "<= 1e-10",
               err <= 1e-10});
    }

    void
    check_damping(const FemVerificationOptions &o, Report &rep)
    {
      const BeamModel   beam;
      const std::string mesh =
        (fs::path(o.mesh_dir) / (o.quick ? "beam_2.msh" : "beam_4.msh")).string();
      const double zeta = 0.02;
      // f1 of this very mesh, so that the Rayleigh fit gives zeta exactly at mode 1.
      double f1;
      {
        ElasticDynamics probe(scene_from(
          beam_scene_json(mesh, 2, beam, R"(, "time": {"step_s": 1, "duration_s": 1})")));
        f1 = probe.natural_frequencies(1)[0];
      }
      const double period = 1 / f1, dt = period / 200;
      const unsigned n_steps = 1600; // 8 periods
      std::ostringstream extra;
      extra.precision(17);
      extra << R"(, "damping": {"ratios": [)" << zeta << ", " << zeta
            << R"(], "frequencies_Hz": [)" << f1 << ", " << 5 * f1 << R"(]},
            "initial_state": "static", "time": {"step_s": )" << dt << R"(, "duration_s": )"
            << n_steps * dt << R"(},
            "loads": [{"type": "surface_force", "surface": "tip", "total_force_N": [0, 0, -1e-4],
                       "history": {"times_s": [0, )" << dt << R"(], "factors": [1, 0]}}],
            "outputs": {"vertices": [{"name": "tip", "vertex": {"nearest_to_m": [)"
            << beam.length << ", " << beam.side / 2 << ", " << beam.side / 2 << "]}}]}";
      ElasticDynamics fem(scene_from(beam_scene_json(mesh, 2, beam, extra.str())));
      const RunResult r = fem.run();
      std::vector<double> s;
      for (const auto &u : r.vertex_displacement.at("tip"))
        s.push_back(u[2] / r.vertex_displacement.at("tip")[0][2]);
      // Positive peaks, refined by a parabola through the three samples around each.
      std::vector<double> peak_t, peak_v;
      for (std::size_t k = 1; k + 1 < s.size(); ++k)
        if (s[k] > s[k - 1] && s[k] >= s[k + 1] && s[k] > 0)
          {
            const double a = 0.5 * (s[k - 1] - 2 * s[k] + s[k + 1]);
            const double b = 0.5 * (s[k + 1] - s[k - 1]);
            const double x = -b / (2 * a);
            peak_t.push_back(r.time[k] + x * dt);
            peak_v.push_back(s[k] + b * x + a * x * x);
          }
      double measured = 0, delta = 0;
      if (peak_v.size() >= 3)
        {
          delta    = std::log(peak_v.front() / peak_v.back()) / (peak_v.size() - 1);
          measured = delta / std::sqrt(4 * M_PI * M_PI + delta * delta);
        }
      const double err = measured / zeta - 1;
      write_csv(rep.path("damping.csv"), {"time_s", "tip_uz_normalized"}, {r.time, s});
      rep.values.insert({{"damping_mesh", fs::path(mesh).filename().string()},
                         {"zeta", plain(zeta)},
                         {"damping_f1", fmt("%.5g", f1)},
                         {"n_peaks", plain(static_cast<double>(peak_v.size()))},
                         {"delta", fmt("%.5f", delta)},
                         {"zeta_measured", fmt("%.5f", measured)},
                         {"zeta_error", fmt("%+.2f %%", 100 * err)}});
      rep.add({"log decrement vs prescribed damping ratio", fmt("%+.2f %%", 100 * err),
               "|error| <= 5 %", peak_v.size() >= 3 && std::abs(err) <= 0.05});
    }

    void
    check_prescribed(const FemVerificationOptions &o, Report &rep)
    {
      // Probe presses the cat's back 1 cm down over 0.2 s (smooth ramp), holds, releases.
      std::ostringstream ramp_t, ramp_f;
      for (int i = 0; i <= 10; ++i)
        {
          const double x = i / 10.0;
          ramp_t << (i ? ", " : "") << 0.2 * x;
          ramp_f << (i ? ", " : "") << x * x * (3 - 2 * x);
        }
      const std::string common =
        R"(, "damping": {"ratios": [0.05, 0.05], "frequencies_Hz": [2, 20]},
           "time": {"step_s": 0.002, "duration_s": 0.6},
           "outputs": {"vertices": [{"name": "ear", "vertex": {"nearest_to_m": [0.03, 0.03, 0.2]}}]})";
      std::string table = "";
      double      worst = 0, worst_other = 0, peak_force = 0;
      std::vector<std::vector<double>> cols;
      for (const std::string &integrator :
           {std::string(R"({"type": "newmark"})"),
            std::string(R"({"type": "generalized_alpha", "rho_inf": 0.8})")})
        {
          const std::string probe_json =
            R"(, "integrator": )" + integrator + common + R"(, "prescribed_displacements": [
                {"name": "probe", "vertex": {"nearest_to_m": [-0.035, 0, 0.13]},
                 "displacement_m": [0, 0, -0.01],
                 "history": {"times_s": [)" + ramp_t.str() + ", 0.5, 0.55" +
            R"(], "factors": [)" + ramp_f.str() + ", 1, 0" + "]}}]";
          const std::string mesh = (fs::path(o.mesh_dir) / "cat.msh").string();
          ElasticDynamics   a(scene_from(cat_scene_json(mesh, 1, probe_json)));
          const RunResult   ra = a.run();
          // Same scene, the probe replaced by its reported force as a vertex load.
          Scene sb = a.scene();
          sb.prescribed.clear();
          fem::VertexForce load;
          load.name        = "replayed";
          load.vertex.node_tag = ra.vertex_node_tag.at("probe");
          load.force.times  = ra.time;
          load.force.values = ra.probe_force.at("probe");
          sb.vertex_forces.push_back(load);
          sb.outputs.vertices.push_back({"probe", load.vertex});
          ElasticDynamics b(sb);
          const RunResult rb = b.run();
          double g_max = 0, err = 0, other_max = 0, other_err = 0;
          for (std::size_t k = 0; k < ra.time.size(); ++k)
            for (unsigned d = 0; d < 3; ++d)
              {
                const double g = ra.probe_displacement.at("probe")[k][d];
                g_max = std::max(g_max, std::abs(g));
                err   = std::max(err, std::abs(rb.vertex_displacement.at("probe")[k][d] - g));
                const double e = ra.vertex_displacement.at("ear")[k][d];
                other_max = std::max(other_max, std::abs(e));
                other_err =
                  std::max(other_err, std::abs(rb.vertex_displacement.at("ear")[k][d] - e));
                peak_force = std::max(peak_force, std::abs(ra.probe_force.at("probe")[k][d]));
              }
          worst       = std::max(worst, err / g_max);
          worst_other = std::max(worst_other, other_err / other_max);
          table += "| " + std::string(integrator.find("newmark") != std::string::npos
                                          ? "Newmark"
                                          : "generalized-alpha 0.8") +
                   " | " + fmt("%.3e", err / g_max) + " | " + fmt("%.3e", other_err / other_max) +
                   " |\n";
          if (cols.empty())
            {
              cols.push_back(ra.time);
              for (unsigned d = 0; d < 3; ++d)
                {
                  std::vector<double> c;
                  for (const auto &f : ra.probe_force.at("probe"))
                    c.push_back(f[d]);
                  cols.push_back(c);
                }
              std::vector<double> g;
              for (const auto &u : ra.probe_displacement.at("probe"))
                g.push_back(u[2]);
              cols.push_back(g);
            }
        }
      write_csv(rep.path("prescribed.csv"),
                {"time_s", "probe_Fx_N", "probe_Fy_N", "probe_Fz_N", "probe_uz_m"}, cols);
      rep.values.insert({{"probe_peak_force", fmt("%.4g", peak_force)}, {"prescribed_rows", table}});
      rep.add({"reaction force reproduces the prescribed displacement",
               fmt("%.3e", worst) + " relative (ear " + fmt("%.2e", worst_other) + ")",
               "<= 1e-8", worst <= 1e-8 && worst_other <= 1e-8});
    }

    // 6. Ball on a rigid floor: the nonlinear FEM's peak contact force against Hertz over
    // impact speed (on meshes whose pole scales with Hertz's contact radius), and its
    // convergence with the mesh at the pole and with the penalty.

    /// One ball run against Hertz.
    struct HertzRun
    {
      std::string mesh;
      double      speed = 0, penalty = 0, mass = 0, peak = 0, penetration = 0, seconds = 0;
      HertzBall   hertz() const // Hertz for the FEM's ball, lighter than the sphere
      {
        HertzBall h;
        h.body_mass = mass;
        return h;
      }
      double error() const { return peak / hertz().peak_force(speed) - 1; }
    };

    /// The ball on mesh `mesh` at speed v (penalty 0: the default): 50 steps per Hertz contact
    /// time, run until 0.6 of it past touching (the peak is at half of it).
    HertzRun
    run_ball(const FemVerificationOptions &o, Report &rep, const std::string &mesh, const double v,
             const double penalty)
    {
      const HertzBall ball;
      HertzRun     r{mesh, v, penalty};
      const double tc = ball.contact_time(v), dt = tc / 50;
      const double steps = std::ceil((1e-4 / v + 0.6 * tc) / dt);
      const auto   t0 = std::chrono::steady_clock::now();
      const auto   res = fem::NonlinearElasticity(
                         scene_from(ball_scene_json((fs::path(o.mesh_dir) / mesh).string(),
                                                    ball, v, dt, steps * dt, penalty)))
                         .run();
      r.seconds = seconds_since(t0);
      r.penalty = res.plane_penalty.at("floor");
      r.mass    = 2 * res.kinetic_energy.at(0) / (v * v); // the mesh's, from 1/2 m v^2
      for (std::size_t k = 0; k < res.time.size(); ++k)
        {
          r.peak        = std::max(r.peak, res.plane_force.at("floor")[k][2]);
          r.penetration = std::max(r.penetration, res.plane_penetration.at("floor")[k]);
        }
      rep.log << "  ball " << mesh << " at " << v << " m/s, penalty " << fmt("%.3g", r.penalty)
              << " Pa/m: peak " << fmt("%.4g", r.peak) << " N (Hertz "
              << fmt("%.4g", r.hertz().peak_force(v)) << " N, " << fmt("%+.2f %%", 100 * r.error())
              << "), " << fmt("%.1f", r.seconds) << " s\n";
      return r;
    }

    /// The Hertz study's runs: the speed sweep on coarse and fine meshes, and the convergence
    /// at v0 with the mesh and with the penalty.
    struct HertzStudy
    {
      double                v0 = 0.02; // m/s: also where the mesh and penalty convergence is run
      std::vector<double>   speeds, penalty_factors;
      std::vector<HertzRun> coarse, fine, by_mesh, by_penalty;
      HertzRun              middle; // the coarse run at v0
      /// The finest series that was run: the checks read it.
      const std::vector<HertzRun> &
      best() const
      {
        return fine.empty() ? coarse : fine;
      }
    };

    HertzStudy
    run_hertz_study(const FemVerificationOptions &o, Report &rep)
    {
      // The speed sweep. Every mesh has pole elements of a fixed fraction of Hertz's contact
      // radius a(v) (coarse 0.27 a, fine 0.135 a; meshes/generate.sh), so the discretization
      // error is alike at every speed and what changes is the physics, a / R ~ v^(2/5).
      HertzStudy s;
      const double v0 = s.v0;
      const auto   mesh_at = [&](const double v, const bool fine) -> std::string {
        if (v == v0)
          return fine ? "ball_pole_1.msh" : "ball_pole_2.msh"; // 2.0 / 1.0 mm = 0.27 / 0.135 a
        return "ball_hertz_" + fmt("%g", 1000 * v) + "mms_" + (fine ? "fine" : "coarse") + ".msh";
      };
      std::vector<double> &speeds = s.speeds;
      speeds = {0.00125, 0.0025, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2};
      if (o.quick)
        speeds = {0.0025, 0.02, 0.1};
      const auto has_fine = [&](const double v) { return !o.quick && v <= v0; };
      std::vector<HertzRun> &coarse = s.coarse, &fine = s.fine;
      for (const double v : speeds)
        {
          coarse.push_back(run_ball(o, rep, mesh_at(v, false), v, 0));
          if (has_fine(v))
            fine.push_back(run_ball(o, rep, mesh_at(v, true), v, 0));
        }
      const auto at_v0 = [&](const std::vector<HertzRun> &runs) {
        return *std::find_if(runs.begin(), runs.end(), [&](const HertzRun &r) { return r.speed == v0; });
      };

      s.by_mesh = {run_ball(o, rep, "ball_pole_4.msh", v0, 0), at_v0(coarse)};
      if (!fine.empty())
        s.by_mesh.push_back(at_v0(fine));
      s.middle          = at_v0(coarse);
      s.penalty_factors = {0.1, 1.0, 10.0}; // of the default
      for (const double factor : s.penalty_factors)
        s.by_penalty.push_back(
          factor == 1.0 ? s.middle : run_ball(o, rep, s.middle.mesh, v0, factor * s.middle.penalty));
      return s;
    }

    /// hertz.csv: every run, by series.
    void
    write_hertz_csv(Report &rep, const HertzStudy &s)
    {
      std::vector<std::vector<double>> cols(11);
      const auto add_rows = [&](const std::vector<HertzRun> &runs, const double series) {
        for (const auto &r : runs)
          {
            const HertzBall           h   = r.hertz();
            const std::vector<double> row = {series,
                                             r.speed,
                                             h.contact_radius(r.speed) / h.radius,
                                             r.penalty,
                                             r.mass,
                                             r.peak,
                                             h.peak_force(r.speed),
                                             h.peak_force_finite_ball(r.speed),
                                             r.penetration,
                                             h.max_indentation(r.speed),
                                             r.seconds};
            for (std::size_t i = 0; i < row.size(); ++i)
              cols[i].push_back(row[i]);
          }
      };
      add_rows(s.coarse, 0);
      add_rows(s.fine, 1);
      add_rows(s.by_mesh, 2);
      add_rows(s.by_penalty, 3);
      write_csv(rep.path("hertz.csv"),
                {"series_0coarse_1fine_2mesh_3penalty", "speed_m_s", "hertz_contact_radius_over_R",
                 "penalty_Pa_m", "fem_mass_kg", "fem_peak_N", "hertz_peak_N",
                 "finite_ball_estimate_peak_N", "fem_max_penetration_m", "hertz_max_indentation_m",
                 "seconds"},
                cols);
    }

    /// Section 6 of the report: the speed sweep against Hertz and the convergence tables.
    void
    write_hertz_section(Report &rep, const HertzStudy &s)
    {
      const HertzBall ball;
      const auto &coarse = s.coarse;
      const auto &fine = s.fine;
      const auto &best = s.best();
      const double v0 = s.v0;
      std::string rows;
      for (const auto &c : coarse)
        {
          const HertzBall h  = c.hertz();
          const auto      f  = std::find_if(fine.begin(), fine.end(),
                                      [&](const HertzRun &r) { return r.speed == c.speed; });
          const HertzRun &fb = f != fine.end() ? *f : c; // the estimate at the finest mass
          const double    est = fb.hertz().peak_force_finite_ball(c.speed);
          rows += "| " + plain(c.speed) + " | " + fmt("%.3f", h.contact_radius(c.speed) / h.radius) +
                  " | " + fmt("%.4g", h.peak_force(c.speed)) + " | " + fmt("%.4g", c.peak) + " | " +
                  fmt("%+.2f %%", 100 * c.error()) + " | " +
                  (f != fine.end() ? fmt("%.4g", f->peak) + " | " + fmt("%+.2f %%", 100 * f->error())
                                   : std::string("- | -")) +
                  " | " + fmt("%+.2f %%", 100 * (est / fb.hertz().peak_force(c.speed) - 1)) + " | " +
                  (f != fine.end() ? fmt("%+.2f %%", 100 * (f->peak / est - 1)) : std::string("-")) +
                  " | " + fmt("%.0f", c.seconds) +
                  (f != fine.end() ? ", " + fmt("%.0f", f->seconds) : std::string()) + " |\n";
        }
      std::string convergence;
      const auto  conv_row = [&](const std::string &name, const HertzRun &r) {
        convergence += "| " + name + " | " + fmt("%.3g", r.penalty) + " | " + fmt("%.4g", r.peak) +
                       " | " + fmt("%+.2f %%", 100 * r.error()) + " | " +
                       fmt("%.3f", r.penetration / r.hertz().max_indentation(r.speed)) + " | " +
                       fmt("%.1f", r.seconds) + " |\n";
      };
      for (const auto &r : s.by_mesh)
        conv_row(r.mesh, r);
      for (std::size_t i = 0; i < s.by_penalty.size(); ++i)
        conv_row(s.middle.mesh + ", penalty x " + fmt("%g", s.penalty_factors[i]), s.by_penalty[i]);
      rep.values.insert({{"ball_radius", plain(ball.radius)},
                         {"ball_youngs", plain(ball.youngs_modulus)},
                         {"ball_nu", plain(ball.poisson_ratio)},
                         {"ball_rho", plain(ball.density)},
                         {"first_mass", fmt("%.4f", best.front().mass)},
                         {"mass_vs_sphere", fmt("%+.2f %%", 100 * (best.front().mass / ball.mass() - 1))},
                         {"centre_compliance", fmt("%.3g", ball.centre_compliance())},
                         {"hertz_rows", rows},
                         {"v0", plain(v0)},
                         {"middle_mesh", s.middle.mesh},
                         {"convergence_rows", convergence}});
    }

    /// The Hertz checks: the low-speed power law, the excess falling with the speed, the
    /// lowest speed within 5 %, and convergence with the mesh and the penalty.
    void
    add_hertz_checks(Report &rep, const HertzStudy &s)
    {
      const HertzBall ball;
      const auto &best = s.best();
      const auto &fine = s.fine;
      const double v0 = s.v0;
      // Hertz's law F_max ~ v^(6/5): least-squares slope of log F against log v over the
      // low speeds (v <= v0), on the finest series.
      double sx = 0, sy = 0, sxx = 0, sxy = 0, n_low = 0;
      for (const auto &r : best)
        if (r.speed <= v0 * (1 + 1e-12))
          {
            const double x = std::log(r.speed), y = std::log(r.peak);
            sx += x, sy += y, sxx += x * x, sxy += x * y, n_low += 1;
          }
      const double exponent = (n_low * sxy - sx * sy) / (n_low * sxx - sx * sx);
      std::string  excesses;
      bool         falls = true;
      for (std::size_t i = 0; i < best.size() && best[i].speed <= v0 * (1 + 1e-12); ++i)
        {
          excesses += (i ? ", " : "") + fmt("%+.2f %%", 100 * best[i].error());
          if (i > 0)
            falls = falls && best[i - 1].error() < best[i].error();
        }
      const HertzRun &lowest = best.front();
      const double a_low  = lowest.hertz().contact_radius(lowest.speed) / ball.radius;
      const std::string series = fine.empty() ? "coarse" : "fine";
      rep.values.insert({{"n_low", plain(n_low)}, {"series", series}, {"exponent", fmt("%.3f", exponent)}});
      rep.add({"peak force against speed follows Hertz's v^(6/5) at low speed",
               "exponent " + fmt("%.3f", exponent), "1.2 +- 0.05",
               std::abs(exponent - 1.2) <= 0.05});
      rep.add({"peak force's excess over Hertz falls as the speed falls (" + series +
                 " meshes, h / a fixed; " + fmt("%g", s.speeds.front()) + " -> " + fmt("%g", v0) +
                 " m/s)",
               excesses, "smaller at each lower speed", falls});
      rep.add({"Hertz peak force at the lowest speed, " + fmt("%g", lowest.speed) + " m/s (a / R = " +
                 fmt("%.3f", a_low) + ", " + lowest.mesh + ")",
               fmt("%+.2f %%", 100 * lowest.error()), "within 5 %",
               std::abs(lowest.error()) <= 0.05});
      const double dm_coarse = std::abs(s.by_mesh[1].peak - s.by_mesh[0].peak),
                   dm_fine   = std::abs(s.by_mesh.back().peak - s.by_mesh[s.by_mesh.size() - 2].peak);
      if (s.by_mesh.size() == 3)
        rep.add({"peak force converges with the mesh (4 -> 2 -> 1 mm at the pole)",
                 "successive changes " + fmt("%.3g", dm_coarse) + " N, " + fmt("%.3g", dm_fine) +
                   " N",
                 "the second smaller", dm_fine < dm_coarse});
      const double dp_soft  = std::abs(s.by_penalty[1].peak - s.by_penalty[0].peak),
                   dp_stiff = std::abs(s.by_penalty[2].peak - s.by_penalty[1].peak);
      rep.add({"peak force converges with the penalty (x 0.1 -> 1 -> 10)",
               "successive changes " + fmt("%.3g", dp_soft) + " N, " + fmt("%.3g", dp_stiff) +
                 " N (" + fmt("%.2f %%", 100 * dp_stiff / s.by_penalty[2].peak) + ")",
               "the second smaller, and below 1 %",
               dp_stiff < dp_soft && dp_stiff < 0.01 * s.by_penalty[2].peak});
    }

    void
    check_hertz(const FemVerificationOptions &o, Report &rep)
    {
      const HertzStudy s = run_hertz_study(o, rep);
      write_hertz_csv(rep, s);
      write_hertz_section(rep, s);
      add_hertz_checks(rep, s);
    }

  } // namespace

  bool
  run_fem_verification(const FemVerificationOptions &o, std::ostream &log)
  {
    std::error_code ec;
    fs::create_directories(o.report_dir, ec);
    if (ec)
      throw InputError("cannot create report folder '" + o.report_dir + "': " + ec.message());
    if (!fs::exists(fs::path(o.mesh_dir) / "cat.msh"))
      throw InputError("no cat.msh in mesh folder '" + o.mesh_dir + "' (see --meshes)");
    Report     rep{{}, {}, o.report_dir, log};
    const auto t0 = std::chrono::steady_clock::now();
    log << "Reference FEM verification -> " << o.report_dir << "\n";
    check_beam(o, rep);
    check_energy(o, rep);
    check_gravity(o, rep);
    check_damping(o, rep);
    check_prescribed(o, rep);
    check_hertz(o, rep);
    const double total = seconds_since(t0);

    bool all = true;
    for (const auto &c : rep.checks)
      all = all && c.pass;
    std::string check_rows;
    for (const auto &c : rep.checks)
      check_rows += "| " + c.name + " | " + c.measured + " | " + c.criterion + " | " +
                    (c.pass ? "pass" : "**FAIL**") + " |\n";
    rep.values.insert({{"stamp", report_stamp()},
                       {"flags", o.quick ? " --quick" : ""},
                       {"version", IRDM_VERSION},
                       {"total_s", fmt("%.0f", total)},
                       {"check_rows", check_rows}});
    write_text_file(rep.path("report.md"),
                    fill_template(read_template("validation/templates/verify_fem.md"), rep.values));

    // Charts: matplotlib from Debian (/usr/bin/python3); the report stands without them.
    const fs::path script = fs::path(o.mesh_dir).parent_path() / "validation" / "plot_fem_verification.py";
    if (fs::exists(script))
      {
        const std::string cmd = "/usr/bin/python3 '" + script.string() + "' '" + o.report_dir + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "note: charts not drawn (needs /usr/bin/python3 with matplotlib)\n";
      }
    log << (all ? "all checks passed" : "SOME CHECKS FAILED") << "; report: "
        << rep.path("report.md") << " (" << fmt("%.0f", total) << " s)\n";
    return all;
  }
} // namespace irdm::validation
