// The free body against the nonlinear FEM (validation/free_body_validation.h).
#include <irdm/free_body.h>
#include <irdm/modal_model.h>
#include <irdm_common/error.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/files.h>
#include <irdm_common/rigid_fit.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>
#include <reference_fem/virtual_dof.h>
#include <validation/free_body_validation.h>

#include "metrics.h"
#include "scene_runs.h"

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <type_traits>

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
      bool            wall     = false;
      double          duration = 0; // s; 0: the options' duration
      // A probe: a known force (N, world) on the surface vertex farthest along +x above the
      // centre of mass, held until probe_seconds, then off within a step. Zero: none.
      Eigen::Vector3d probe_force   = Eigen::Vector3d::Zero();
      double          probe_seconds = 0;
      bool            gravity       = true;
      // > 0: a case of the impact study (impact.csv), at this speed (m/s) and without gravity.
      double impact_speed = 0;
      bool
      in_study() const
      {
        return impact_speed > 0;
      }
    };

    // The impact study: the upright cat 1 mm above the floor, moving toward it at `speed`,
    // gravity off. Linear elasticity with a linear penalty is positively homogeneous: its
    // response scales with the speed, so a linear method's relative error against it does not
    // change with the speed, while linear against nonlinear elasticity shrinks with it.
    Case
    impact_case(const double speed)
    {
      std::ostringstream name;
      name << "impact_" << speed;
      Case c{name.str(), Eigen::Vector3d::UnitZ(), 0.001, Eigen::Vector3d(0, 0, -speed)};
      c.gravity      = false;
      c.duration     = 0.3;
      c.impact_speed = speed;
      return c;
    }

    // Dropped 2 cm spinning at 8 rad/s about y: it rolls over within 2 s (the scene 3).
    Case
    rolling_case()
    {
      return {"spin_roll", Eigen::Vector3d::UnitZ(), 0.02, Eigen::Vector3d::Zero(),
              Eigen::Vector3d(0, 8, 0), false, 2.0};
    }

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
          c.push_back(rolling_case());
          c.push_back({"wall_throw", Eigen::Vector3d::UnitZ(), 0.005, Eigen::Vector3d(0.6, 0, 0),
                       Eigen::Vector3d::Zero(), true});
        }
      c.push_back({"tilted_5cm", tilted, 0.05});
      if (!quick)
        {
          // Resting 1 mm above the floor, pushed back and down at the head for 0.2 s: the
          // probe of issue 14 drives the rigid body and the deformation.
          Case poke{"probe_push", Eigen::Vector3d::UnitZ(), 0.001};
          poke.probe_force   = Eigen::Vector3d(-3, 0, -2);
          poke.probe_seconds = 0.2;
          c.push_back(poke);
        }
      return c;
    }

    double
    angle_deg(const Eigen::Matrix3d &R)
    {
      return Eigen::AngleAxisd(R).angle() * 180 / M_PI;
    }

    struct Row
    {
      std::string c, method;
      double      E = 0;
      double      com_error = 0, angle_error = 0, force_error = 0, impulse_error = 0,
             deformation_error = 0, irdm_us = 0, fem_ms = 0, peak_ratio = 0, rotation_deg = 0,
             turned_deg = 0, centrifugal = 0, energy_growth = 0;
      bool        stable = true;
      double      impact_speed = 0; // m/s: a row of the impact study (impact.csv), not free.csv
      std::string fem_failed; // the FEM's error message when it could not run the case
      // The first contact alone (the FEM's first step with a plane force to its first step
      // without, after it): before the paths can part at a later bounce.
      double first_start = 0, first_end = 0, first_force_error = 0, first_impulse_error = 0,
             first_deformation_error = 0;
    };

    std::string
    format_g(const double x)
    {
      std::ostringstream s;
      s << x;
      return s.str();
    }

    // A FEM run at tau / M (the truth's own step, --fem-divisions) as samples at tau, the
    // runtime's step: the plane forces, the centre of mass and the surface taken at every
    // tau, in place. Returns the plane forces' impulse over each step of tau (index 1..n; 0
    // holds zero), summed at the FEM's own step with the right-point rule the runtime's
    // impulse uses, so that a force that changes within tau is not sampled away. M = 1 leaves
    // the run as it is and gives tau F[step].
    std::vector<Eigen::Vector3d>
    sample_at_tau(fem::RunResult &r, const unsigned M, const double tau)
    {
      const size_t n = (r.time.size() - 1) / M;
      if (r.time.size() != M * n + 1)
        throw std::logic_error("validate-free: a FEM run of " + std::to_string(r.time.size()) +
                            " samples is not whole steps of tau at " + std::to_string(M) +
                            " FEM steps each");
      std::vector<Eigen::Vector3d> impulse(n + 1, Eigen::Vector3d::Zero());
      for (const auto &[name, F] : r.plane_force)
        for (size_t step = 1; step <= n; ++step)
          for (size_t q = M * (step - 1) + 1; q <= M * step; ++q)
            impulse[step] += tau / M * vec(F[q]);
      if (M == 1)
        return impulse; // already at tau (and a vector moved onto itself would be emptied)
      const auto every_mth = [&](auto &series) {
        for (size_t step = 1; step <= n; ++step)
          series[step] = std::move(series[M * step]);
        series.resize(n + 1);
      };
      for (auto &[name, F] : r.plane_force)
        every_mth(F);
      every_mth(r.center_of_mass_displacement);
      every_mth(r.surface_displacement);
      every_mth(r.time);
      return impulse;
    }

    // One run, the FEM's (sampled at tau) or the runtime's, as the error measures take it: at
    // every step of tau (index 1..n; 0 unused) the total plane force, its impulse over the step,
    // the centre of mass and the surface's best-fit pose and deformation.
    struct Samples
    {
      std::vector<Eigen::Vector3d> force, impulse, com;
      std::vector<RigidFit>        fit;
      explicit Samples(const unsigned n)
        : force(n + 1, Eigen::Vector3d::Zero())
        , impulse(n + 1, Eigen::Vector3d::Zero())
        , com(n + 1, Eigen::Vector3d::Zero())
        , fit(n + 1)
      {}
      unsigned
      steps() const
      {
        return static_cast<unsigned>(force.size() - 1);
      }
    };

    // A run's errors against a reference run, by the measures report.md defines: over the whole
    // run, and over the steps [window_begin, window_end) (the first contact).
    struct RunErrors
    {
      double com = 0, angle = 0, force = 0, impulse = 0, deformation = 0, distance = 0;
      double window_force = 0, window_impulse = 0, window_deformation = 0;
    };

    RunErrors
    compare(const Samples &reference, const Samples &run, const Eigen::Vector3d &c0,
            const unsigned window_begin, const unsigned window_end)
    {
      RunErrors       e;
      RelativeL2      force, deformation, window_force, window_deformation;
      Eigen::Vector3d J = Eigen::Vector3d::Zero(), J_run = Eigen::Vector3d::Zero(),
                      wJ = Eigen::Vector3d::Zero(), wJ_run = Eigen::Vector3d::Zero(), c_prev = c0;
      for (unsigned step = 1; step <= reference.steps(); ++step)
        {
          const Eigen::Vector3d &F = reference.force[step], &F_run = run.force[step];
          const double           step_f2 = F.squaredNorm(), step_df2 = (F - F_run).squaredNorm();
          force.add_squared(step_df2, step_f2);
          J += reference.impulse[step], J_run += run.impulse[step];
          e.distance += (reference.com[step] - c_prev).norm(), c_prev = reference.com[step];
          e.com = std::max(e.com, (reference.com[step] - run.com[step]).norm());
          const RigidFit &ff = reference.fit[step], &fr = run.fit[step];
          e.angle = std::max(e.angle, angle_deg(fr.rotation * ff.rotation.transpose()));
          double step_d2 = 0, step_dd2 = 0;
          for (size_t v = 0; v < ff.deformation.size(); ++v)
            step_d2 += ff.deformation[v].squaredNorm(),
              step_dd2 += (ff.deformation[v] - fr.deformation[v]).squaredNorm();
          deformation.add_squared(step_dd2, step_d2);
          if (step >= window_begin && step < window_end)
            {
              window_force.add_squared(step_df2, step_f2);
              wJ += reference.impulse[step], wJ_run += run.impulse[step];
              window_deformation.add_squared(step_dd2, step_d2);
            }
        }
      e.com /= std::max(e.distance, 1e-12);
      e.force              = force.value();
      e.impulse            = (J_run - J).norm() / std::max(J.norm(), 1e-300);
      e.deformation        = deformation.value();
      e.window_force       = window_force.value();
      e.window_impulse     = (wJ_run - wJ).norm() / std::max(wJ.norm(), 1e-300);
      e.window_deformation = window_deformation.value();
      return e;
    }

    // One row of linearization.csv: a run against a reference over the first contact and the
    // whole run (method error and linearization apart).
    struct LinearizationRow
    {
      std::string c, method, reference;
      double      E = 0, start = 0, end = 0, rotation_deg = 0;
      double      impact_speed = 0; // m/s: the impact study's (impact.csv)
      RunErrors   errors;
      std::string failed; // the linear FEM's error message when it could not run
    };

    // How far the truth is from small strain in one case (truth_strain.csv): the largest
    // principal stretch departure and the volume fraction past 10 %, over the first contact and
    // the whole run (RunResult::largest_strain).
    struct StrainRow
    {
      std::string c;
      double      E = 0, start = 0, end = 0, impact_speed = 0;
      double      first_largest = 0, first_fraction = 0, run_largest = 0;
    };

    // A FEM run at tau / M as Samples at tau (sample_at_tau), its surface read at the
    // comparison's vertices (`node_tags`, rest positions `rest`); `x`, when given, receives the
    // surfaces.
    Samples
    fem_samples(fem::RunResult &r, const unsigned M, const double tau,
                const std::vector<fem::RigidPlane> &planes, const std::vector<Eigen::Vector3d> &rest,
                const std::vector<long long> &node_tags, const Eigen::Vector3d &c0,
                std::vector<std::vector<Eigen::Vector3d>> *x = nullptr)
    {
      std::vector<Eigen::Vector3d> impulse = sample_at_tau(r, M, tau);
      const unsigned               n       = static_cast<unsigned>(impulse.size() - 1);
      Samples                      s(n);
      s.impulse = std::move(impulse);
      std::map<long long, unsigned> at;
      for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
        at[r.surface.node_tags[i]] = i;
      std::vector<Eigen::Vector3d> xs(rest.size());
      if (x)
        x->assign(n + 1, std::vector<Eigen::Vector3d>(rest.size()));
      for (unsigned step = 1; step <= n; ++step)
        {
          for (const auto &pl : planes)
            s.force[step] += vec(r.plane_force.at(pl.name)[step]);
          s.com[step] = c0 + vec(r.center_of_mass_displacement[step]);
          for (size_t v = 0; v < rest.size(); ++v)
            {
              const unsigned j = at.at(node_tags[v]);
              for (int d = 0; d < 3; ++d)
                xs[v](d) = rest[v](d) + r.surface_displacement[step][3 * j + d];
            }
          s.fit[step] = best_rigid_fit(rest, xs);
          if (x)
            (*x)[step] = xs;
        }
      return s;
    }

    // The truth's FEM step divisions for material m: one value for every material, or one each.
    unsigned
    fem_divisions_of(const FreeBodyValidationOptions &o, const size_t m)
    {
      return o.fem_divisions.size() == 1 ? o.fem_divisions[0] : o.fem_divisions[m];
    }

    std::string
    material_name(const double E)
    {
      std::ostringstream s;
      s << E / 1000 << "kPa";
      return s.str();
    }

    // The two routes of issue 14 (reference_fem/impulse_response.h, FreeBodyRoute).
    struct Route
    {
      const char        *method; // free.csv's method column
      fem::FreeBodyRoute route;
      const char        *file_suffix;
    };
    constexpr const char *vdof_method = "vdof_rigid_fit"; // the seed's virtual DOFs, route 1
    constexpr Route routes[] = {{"route1_rigid_fit", fem::FreeBodyRoute::rigid_fit, "_rigid_fit"},
                                {"route2_modal", fem::FreeBodyRoute::modal, ""}};

    // A modal realization and its free.csv method name.
    struct NamedModel
    {
      std::string method;
      ModalModel  model;
      bool        impact_study_only = false; // run on the impact study's cases alone
    };

    // Precomputes the body's model by one route and keeps its modal realization (H itself,
    // a gigabyte for the cat, is dropped), with surface_modes in its surface (0: every mode);
    // with force_modes > 0 also the realization with that many modes in the force loop (the
    // rest quasi-static), named method + "_k<K>"; with study_surface_modes > 0 also the
    // every-mode realization with that many in its surface, method + "_s<M>", for the impact
    // study alone.
    std::vector<NamedModel>
    free_model(const fem::Scene &body, const std::string &file, const fem::FreeBodyRoute route,
               const std::string &method, const unsigned surface_modes,
               const unsigned force_modes, const unsigned study_surface_modes, std::ostream &log)
    {
      fem::PrecomputeOptions po;
      po.output      = file;
      po.restart     = true;
      po.free_route  = route;
      po.fit_weights = fem::RigidFitWeights::uniform;
      log << "validate-free: precomputing " << file << std::endl;
      fem::precompute_impulse_responses(body, po);
      const ImpulseResponseModel model = load_model(file, body.time_step);
      const unsigned             all = model.modes.n_modes;
      ModalModelOptions          mo;
      mo.surface_modes = surface_modes == 0 ? all : std::min(surface_modes, all);
      std::vector<NamedModel> out;
      out.push_back({method, make_modal_model(model, mo)});
      if (force_modes > 0 && force_modes < all)
        {
          ModalModelOptions k = mo;
          k.force_modes       = force_modes;
          k.surface_modes     = std::min(mo.surface_modes, force_modes);
          out.push_back({method + "_k" + std::to_string(force_modes), make_modal_model(model, k)});
        }
      if (study_surface_modes > 0 && study_surface_modes < mo.surface_modes)
        {
          ModalModelOptions m = mo;
          m.surface_modes     = study_surface_modes;
          out.push_back({method + "_s" + std::to_string(study_surface_modes),
                         make_modal_model(model, m), true});
        }
      return out;
    }

    // Energy the runtime's body has above its start, less a probe's work on it, (E(t) - E(0) -
    // W(t)) / E_in: E = rigid kinetic + deformation + gravity's potential; E_in = the initial
    // kinetic energy plus the weight times the drop height plus the probe's work (its absolute
    // value step by step), what the scene brings in. (Virtual DOFs: no deformation energy.)
    template <class Body>
    struct EnergyWatch
    {
      const Body     &irdm;
      Eigen::Vector3d gravity;
      double          e0 = 0, e_in = 1;
      double          work = 0, work_in = 0; // a probe's work on the body, and its size
      double
      energy() const
      {
        return irdm.energy() - irdm.rigid().inertia().mass * gravity.dot(irdm.rigid().state().position);
      }
      void
      start(const double height)
      {
        e0   = energy();
        e_in = irdm.rigid().kinetic_energy() + irdm.rigid().inertia().mass * gravity.norm() * height;
      }
      /// A probe's work over the latest step (J): the energy may grow by it.
      void
      add_work(const double w)
      {
        work += w;
        work_in += std::abs(w);
      }
      double
      growth() const
      {
        return (energy() - e0 - work) / std::max(e_in + work_in, 1e-300);
      }
    };
  } // namespace

  void
  run_free_body_validation(const FreeBodyValidationOptions &o, std::ostream &log)
  {
    // The linear FEM's run name (linearization.csv, impact.csv).
    const char *linear_fem = o.body_frame ? "fem_linear_body_frame" : "fem_small_strain";
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
    if (o.fem_divisions.size() != 1 && o.fem_divisions.size() != o.materials.size())
      throw InputError("validate-free: --fem-divisions gives " +
                       std::to_string(o.fem_divisions.size()) + " values for " +
                       std::to_string(o.materials.size()) +
                       " materials: give one for every material, or one per material");
    for (const unsigned M : o.fem_divisions)
      if (M == 0)
        throw InputError("validate-free: --fem-divisions must be at least 1");
    const std::string dir = (fs::path(o.report_dir) / "free").string();
    fs::create_directories(dir);
    fs::create_directories(o.model_dir);
    // Two runs never write the same report or models at once.
    const OutputLock report_lock((fs::path(dir) / "free.csv").string());
    const OutputLock models_lock((fs::path(o.model_dir) / "free_cat").string());

    std::vector<Row>              rows;
    std::vector<LinearizationRow> linearization; // linearization.csv
    std::vector<StrainRow>        strain_rows;   // truth_strain.csv
    // Series per time step (series.csv), the surfaces at a few times of the rolling cat
    // (frames.csv), and the long runs of the runtime alone (stability).
    std::ostringstream series, frames;
    series << "case,material,method,time_s,fem_force_N,irdm_force_N,fem_com_z_m,irdm_com_z_m,"
              "fem_angle_deg,irdm_angle_deg,fem_deformation_rms_m,deformation_difference_rms_m\n";
    frames << "case,material,method,time_s,vertex,x_m,y_m,z_m\n";
    std::ostringstream       stability;
    // The long runs' energy over time, every 0.1 s (stability.csv).
    std::ostringstream stability_csv;
    stability_csv << "material,method,time_s,energy_gain,elastic_energy_over_input,turned_deg,"
                     "active_vertices,deepest_below_floor_m\n";
    // The truth's own determination (--truth-check): the FEM at tau / 2M against the FEM at tau / M.
    std::ostringstream truth_csv, truth_md;
    truth_csv << "case,material,com_error,angle_error_deg,force_error,impulse_error,"
                 "deformation_error,fem_half_step_ms_per_tau\n";
    std::vector<std::string> free_flight_lines;
    std::vector<std::array<unsigned, 3>> triangles;
    // The impact study joins a full run, or a run that names it (--cases impact).
    const bool study = !o.impact_speeds.empty() &&
                       (std::find(o.only_cases.begin(), o.only_cases.end(), "impact") != o.only_cases.end() ||
                        (o.only_cases.empty() && !o.quick));
    for (size_t material = 0; material < o.materials.size(); ++material)
      {
        const double   E = o.materials[material];
        const unsigned M = fem_divisions_of(o, material);
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

        std::vector<NamedModel> models;
        for (const Route &route : routes)
          for (NamedModel &m : free_model(
                 body,
                 (fs::path(o.model_dir) / ("free_cat_" + material_name(E) + route.file_suffix + ".h5")).string(),
                 route.route, route.method,
                 o.surface_modes, o.force_modes,
                 study && route.route == fem::FreeBodyRoute::modal ? o.study_surface_modes : 0, log))
            models.push_back(std::move(m));
        const ModalModel &frame = models.back().model; // the mesh, the vertices, the mass: shared
        triangles               = frame.triangles;
        std::vector<Eigen::Vector3d> rest(frame.n_outputs / 3);
        for (size_t v = 0; v < rest.size(); ++v)
          rest[v] = vec(frame.output_coordinates[v]);
        const Eigen::Vector3d c0   = vec(frame.center_of_mass);
        const double          mass = frame.mass;
        const double r_gyration = std::sqrt(0.5 * (frame.inertia[0][0] + frame.inertia[1][1] +
                                                   frame.inertia[2][2]) / mass);
        std::vector<unsigned> identity(rest.size());
        for (unsigned v = 0; v < identity.size(); ++v)
          identity[v] = v;
        // The seed's virtual DOFs of the free body (route 1 with the nonlinear FEM's wall hits).
        std::optional<VirtualDofModel> vdof;
        std::vector<unsigned>          vdof_order(rest.size());
        if (o.vdof_subdivisions >= 0)
          {
            const std::string file =
              (fs::path(o.model_dir) / ("free_cat_" + material_name(E) + "_vdof.h5")).string();
            if (o.reuse_models && fs::exists(file))
              log << "validate-free: reusing " << file << std::endl;
            else
              {
                fem::VirtualDofOptions vo;
                vo.output       = file;
                vo.subdivisions = static_cast<unsigned>(o.vdof_subdivisions);
                vo.length       = o.vdof_length;
                vo.log          = [&log](const std::string &line) { log << line << std::endl; };
                log << "validate-free: precomputing " << file << std::endl;
                fem::precompute_virtual_dofs(body, vo);
              }
            vdof = load_virtual_dof_model(file, tau);
            if (!vdof->free_body)
              throw InputError("validate-free: '" + file + "' is not a free body's model");
            std::map<long long, unsigned> at;
            for (unsigned i = 0; i < vdof->node_tags.size(); ++i)
              at[vdof->node_tags[i]] = i;
            for (size_t v = 0; v < rest.size(); ++v)
              {
                const auto it = at.find(frame.output_node_tags[v]);
                if (it == at.end())
                  throw InputError("validate-free: the virtual-DOF model's surface lacks a vertex "
                                   "of the modal model's");
                vdof_order[v] = it->second;
              }
          }

        double floor_penalty = 0; // Pa/m: the FEM's, from its runs
        std::vector<Case> chosen;
        for (const Case &k : cases(o.quick && o.only_cases.empty()))
          if (o.only_cases.empty() ||
              std::find(o.only_cases.begin(), o.only_cases.end(), k.name) != o.only_cases.end())
            chosen.push_back(k);
        for (const double v : o.impact_speeds)
          if (study)
            chosen.push_back(impact_case(v));
        for (const Case &k : chosen)
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
            const double duration = k.duration > 0 ? k.duration : o.duration;
            // The probe's vertex and force history, the same for the FEM and the runtime.
            const bool   probed = k.probe_force.norm() > 0;
            unsigned     probe_vertex = 0;
            fem::History probe_history;
            if (probed)
              {
                double best = -1e300;
                for (size_t v = 0; v < rest.size(); ++v)
                  if (frame.output_input_index[v] >= 0 && rest[v](2) > c0(2) && rest[v](0) > best)
                    best = rest[v](0), probe_vertex = static_cast<unsigned>(v);
                probe_history.times  = {0, k.probe_seconds, k.probe_seconds + tau};
                probe_history.values = {arr(k.probe_force), arr(k.probe_force), {0, 0, 0}};
              }
            fem::Scene s               = body;
            s.kinematics               = fem::Kinematics::nonlinear;
            s.gravity_enabled          = k.gravity;
            s.gravity                  = arr(-9.81 * k.up);
            s.initial_velocity         = arr(k.velocity);
            s.initial_angular_velocity = arr(k.spin);
            s.planes                   = planes;
            s.duration                 = duration;
            s.time_step                = tau / M; // the truth's own step; sampled at tau
            s.vertex_forces.clear();
            if (probed)
              {
                fem::VertexForce probe;
                probe.name            = "probe";
                probe.vertex.node_tag = frame.output_node_tags[probe_vertex];
                probe.force           = probe_history;
                s.vertex_forces.push_back(probe);
              }
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
                std::vector<std::string> methods;
                for (const NamedModel &m : models)
                  if (!m.impact_study_only || k.in_study())
                    methods.push_back(m.method);
                if (vdof && !probed && !k.in_study())
                  methods.push_back(vdof_method);
                for (const std::string &method : methods)
                  {
                    Row row;
                    row.c = k.name, row.method = method, row.E = E, row.fem_failed = e.what();
                    row.impact_speed = k.impact_speed;
                    rows.push_back(row);
                  }
                continue;
              }
            const double fem_seconds = std::chrono::duration<double>(Clock::now() - t_fem).count();
            if (fem_r.cut_steps > 0)
              log << "  the FEM cut back " << fem_r.cut_steps << " of its " << fem_r.n_steps
                  << " steps (Newton failed at the full step; shortest " << fem_r.smallest_step
                  << " s)" << std::endl;
            log << "  the FEM's energy rose at most " << fem_r.energy_rise / fem_r.energy_scale
                << " of its scale above its start"
                << (probed ? " (the probe's work included)" : "") << std::endl;
            floor_penalty = fem_r.plane_penalty.at("floor");
            // The FEM's surface, fitted pose and deformation, once for every method.
            std::vector<std::vector<Eigen::Vector3d>> fem_x;
            const Samples truth = fem_samples(fem_r, M, tau, planes, rest, frame.output_node_tags, c0, &fem_x);
            const unsigned n = truth.steps(); // steps of tau
            // The first contact's steps [first_begin, first_end): from the FEM's first step with
            // a plane force to the first after it that begins 10 ms without any (the run's end
            // if it stays): a foot that leaves the floor for a step and lands again, while the
            // body still presses on, does not end it.
            unsigned       first_begin = n + 1, first_end = n + 1;
            const unsigned quiet = std::max(1u, static_cast<unsigned>(std::lround(0.01 / tau)));
            for (unsigned step = 1, free_steps = 0; step <= n; ++step)
              {
                const bool touching = truth.force[step].norm() > 0;
                if (first_begin > n)
                  first_begin = touching ? step : first_begin;
                else if (touching)
                  free_steps = 0;
                else if (++free_steps == quiet || step == n)
                  {
                    first_end = step + 1 - free_steps;
                    break;
                  }
              }
            {
              StrainRow sr;
              sr.c = k.name, sr.E = E, sr.impact_speed = k.impact_speed;
              sr.start = (first_begin - 1) * tau;
              sr.end   = (std::min(first_end, n + 1) - 1) * tau;
              for (size_t i = 0; i < fem_r.largest_strain.size() && i < fem_r.time.size(); ++i)
                {
                  sr.run_largest = std::max(sr.run_largest, fem_r.largest_strain[i]);
                  if (first_begin <= n && fem_r.time[i] >= sr.start - 1e-9 * tau &&
                      fem_r.time[i] <= sr.end + 1e-9 * tau)
                    {
                      sr.first_largest  = std::max(sr.first_largest, fem_r.largest_strain[i]);
                      sr.first_fraction = std::max(sr.first_fraction, fem_r.strained_volume_fraction[i]);
                    }
                }
              strain_rows.push_back(sr);
              log << "  the FEM's largest strain " << sr.first_largest << " over the first contact ("
                  << sr.first_fraction << " of the volume past 0.1), " << sr.run_largest
                  << " over the run" << std::endl;
            }
            if (o.truth_check && !k.in_study())
              {
                // The FEM at half the step against the FEM at tau, at tau's sample times and
                // by the same measures as the runtime's rows below.
                fem::Scene half = s;
                half.time_step  = s.time_step / 2;
                log << "  the FEM at tau / 2M (truth check)" << std::endl;
                const auto t_half = Clock::now();
                try
                  {
                    fem::RunResult h = fem::NonlinearElasticity(half).run();
                    const double half_ms = 1e3 * std::chrono::duration<double>(Clock::now() - t_half).count() /
                                           n;
                    const RunErrors he = compare(truth, fem_samples(h, 2 * M, tau, planes, rest, frame.output_node_tags, c0),
                                             c0, first_begin, first_end);
                    truth_csv << k.name << ',' << material_name(E) << ',' << he.com << ',' << he.angle << ','
                              << he.force << ',' << he.impulse << ',' << he.deformation << ',' << half_ms << '\n';
                    truth_md << "| " << k.name << " | " << material_name(E) << " | " << he.com << " | "
                             << he.angle << " | " << he.force << " | " << he.impulse << " | "
                             << he.deformation << " | " << half_ms << " |\n";
                    log << "  the FEM at tau / 2M against tau / M: com " << he.com << ", angle " << he.angle
                        << " deg, force " << he.force << ", impulse " << he.impulse
                        << ", deformation " << he.deformation << std::endl;
                  }
                catch (const std::exception &e)
                  {
                    log << "  the FEM at tau / 2M failed: " << e.what() << std::endl;
                    truth_csv << k.name << ',' << material_name(E) << ",nan,nan,nan,nan,nan,nan\n";
                    truth_md << "| " << k.name << " | " << material_name(E)
                             << " | the FEM at tau / 2M failed: " << e.what() << " ||||||\n";
                  }
              }

            // The linear FEM: the same solver, step, mesh and penalty contact with a linear
            // law. Against the truth it is what linear elasticity itself misses (every linear
            // method inherits it); the runtime against it is the method's own error. The
            // body-frame law (material.law "linear_body_frame") is linear elasticity in the
            // body's best-fit frame, what the free routes linearize; the plain small-strain law
            // ("linear") is not objective (a finite turn strains it, and a spin swells the body
            // instead of turning it), so with it a body that starts spinning is left out. Each row states how far the
            // truth had turned.
            std::optional<Samples> small_strain;
            double window_rotation = 0; // the truth's largest rotation before the window's end
            for (unsigned step = 1; step < std::min(first_end, n + 1); ++step)
              window_rotation = std::max(window_rotation, angle_deg(truth.fit[step].rotation));
            const auto linearization_row = [&](const std::string &method, const char *reference) {
              LinearizationRow row;
              row.c = k.name, row.method = method, row.reference = reference, row.E = E;
              row.start        = (first_begin - 1) * tau;
              row.end          = (std::min(first_end, n + 1) - 1) * tau;
              row.rotation_deg = window_rotation;
              row.impact_speed = k.impact_speed;
              return row;
            };
            if (o.small_strain && (o.body_frame || k.spin.norm() == 0))
              {
                fem::Scene lin       = s;
                lin.small_strain_law = true;
                lin.body_frame_law   = o.body_frame;
                log << "  the linear FEM (" << linear_fem << ")" << std::endl;
                LinearizationRow row = linearization_row(linear_fem, "fem_neo_hookean");
                try
                  {
                    fem::RunResult l = fem::NonlinearElasticity(lin).run();
                    small_strain     = fem_samples(l, M, tau, planes, rest, frame.output_node_tags, c0);
                    row.errors       = compare(truth, *small_strain, c0, first_begin, first_end);
                    log << "  the linear FEM against the truth: first contact: force "
                        << row.errors.window_force << ", impulse " << row.errors.window_impulse
                        << ", deformation " << row.errors.window_deformation << std::endl;
                  }
                catch (const std::exception &e)
                  {
                    log << "  the linear FEM failed: " << e.what() << std::endl;
                    row.failed = e.what();
                  }
                linearization.push_back(row);
              }

            // Frames of the rolling cat: six times evenly over the run.
            const bool     with_frames = k.name == "spin_roll";
            const auto     is_frame    = [&](const unsigned step) {
              return with_frames && step % std::max(1u, n / 6) == 0;
            };
            const auto     write_frame = [&](const char *method, const unsigned step,
                                         const std::vector<Eigen::Vector3d> &x) {
              for (size_t v = 0; v < x.size(); ++v)
                frames << k.name << ',' << material_name(E) << ',' << method << ',' << step * tau
                       << ',' << v << ',' << x[v](0) << ',' << x[v](1) << ',' << x[v](2) << '\n';
            };
            for (unsigned step = 1; step <= n; ++step)
              if (is_frame(step))
                write_frame("fem", step, fem_x[step]);

            // The runtime by one method, with the FEM's penalty as a per-vertex stiffness
            // (many-vertex contact; the virtual DOFs' walls are rigid). `order[v]`: the
            // runtime's index of the comparison's vertex v.
            FreeBodyOptions fo;
            fo.gravity     = k.gravity ? Eigen::Vector3d(-9.81 * k.up) : Eigen::Vector3d::Zero();
            fo.centrifugal      = o.centrifugal;
            fo.deformed_inertia = o.deformed_inertia;
            const auto run_method = [&](auto &irdm, const char *method,
                                        const std::vector<unsigned> &order) {
                irdm.rigid().set_velocity(k.velocity, k.spin);
                std::vector<PlaneTarget> targets(planes.size());
                for (size_t p = 0; p < planes.size(); ++p)
                  {
                    targets[p].normal    = planes[p].normal;
                    targets[p].point     = planes[p].position.at(0);
                    // The FEM's penalty, each vertex weighed by its lumped area as the
                    // FEM's P1 contact weighs it (the virtual-DOF kind uses its own wall).
                    targets[p].penalty = fem_r.plane_penalty.at(planes[p].name);
                  }
                EnergyWatch<std::decay_t<decltype(irdm)>> watch{irdm, fo.gravity};
                watch.start(k.height);
                Eigen::Vector3d probe_prev = rest[probe_vertex]; // world = model frame at t = 0

                Row row;
                row.c = k.name, row.method = method, row.E = E;
                row.impact_speed = k.impact_speed;
                row.fem_ms = 1e3 * fem_seconds / n;
                std::vector<double>          x(3 * irdm.deformation().n_vertices());
                std::vector<Eigen::Vector3d> xi(rest.size());
                Samples                      run(n);
                double peak_f = 0, peak_i = 0, step_seconds = 0, centrifugal = 0,
                       peak_contact = mass * 9.81;
                Eigen::Matrix3d R_prev = Eigen::Matrix3d::Identity();
                for (unsigned step = 1; step <= n; ++step)
                  {
                    const auto t0 = Clock::now();
                    const PointForce probe{probe_vertex, vec(probe_history.at(step * tau))};
                    const bool ok = probed ? irdm.step(targets.data(), static_cast<int>(targets.size()), &probe, 1)
                                           : irdm.step(targets.data(), static_cast<int>(targets.size()));
                    step_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
                    row.stable = row.stable && ok;
                    irdm.surface_positions(x.data());
                    const Eigen::Vector3d &F_f = truth.force[step];
                    Eigen::Vector3d       &F_i = run.force[step];
                    for (size_t p = 0; p < planes.size(); ++p)
                      F_i += irdm.plane_force(static_cast<int>(p));
                    run.impulse[step] = tau * F_i;
                    peak_f = std::max(peak_f, F_f.norm()), peak_i = std::max(peak_i, F_i.norm());
                    peak_contact = std::max(peak_contact, F_f.norm());
                    const Eigen::Vector3d &c_f = truth.com[step];
                    const Eigen::Vector3d &c_i = run.com[step] = irdm.rigid().state().position;
                    for (size_t v = 0; v < rest.size(); ++v)
                      {
                        const unsigned j = order[v];
                        xi[v]      = Eigen::Vector3d(x[3 * j], x[3 * j + 1], x[3 * j + 2]);
                        row.stable = row.stable && xi[v].allFinite();
                      }
                    const RigidFit &ff = truth.fit[step], &fi = run.fit[step] = best_rigid_fit(rest, xi);
                    row.rotation_deg = std::max(row.rotation_deg, angle_deg(ff.rotation));
                    row.turned_deg += angle_deg(ff.rotation * R_prev.transpose());
                    R_prev = ff.rotation;
                    double step_d2 = 0, step_dd2 = 0; // for series.csv
                    for (size_t v = 0; v < rest.size(); ++v)
                      step_d2 += ff.deformation[v].squaredNorm(),
                        step_dd2 += (ff.deformation[v] - fi.deformation[v]).squaredNorm();
                    const double w = irdm.rigid().angular_velocity().norm();
                    centrifugal    = std::max(centrifugal, mass * w * w * r_gyration);
                    if (probed)
                      {
                        // The probe's work this step, trapezoidal as the loads (samples at the
                        // steps' ends).
                        const Eigen::Vector3d F0 = vec(probe_history.at((step - 1) * tau)),
                                              F1 = vec(probe_history.at(step * tau));
                        const Eigen::Vector3d p  = xi[probe_vertex];
                        watch.add_work(0.5 * (F0 + F1).dot(p - probe_prev));
                        probe_prev = p;
                      }
                    row.energy_growth = std::max(row.energy_growth, watch.growth());
                    if (!k.in_study())
                      series << k.name << ',' << material_name(E) << ',' << method << ','
                           << step * tau << ',' << F_f.dot(k.up) << ',' << F_i.dot(k.up) << ','
                           << c_f(2) << ',' << c_i(2) << ',' << angle_deg(ff.rotation) << ','
                           << angle_deg(fi.rotation) << ',' << std::sqrt(step_d2 / rest.size())
                           << ',' << std::sqrt(step_dd2 / rest.size()) << '\n';
                    if (is_frame(step))
                      write_frame(method, step, xi);
                  }
                const RunErrors err = compare(truth, run, c0, first_begin, first_end);
                row.com_error = err.com, row.angle_error = err.angle, row.force_error = err.force;
                row.impulse_error = err.impulse, row.deformation_error = err.deformation;
                row.first_start       = (first_begin - 1) * tau;
                row.first_end         = (std::min(first_end, n + 1) - 1) * tau;
                row.first_force_error = err.window_force, row.first_impulse_error = err.window_impulse;
                row.first_deformation_error = err.window_deformation;
                if (small_strain)
                  {
                    LinearizationRow against = linearization_row(method, linear_fem);
                    against.errors = compare(*small_strain, run, c0, first_begin, first_end);
                    linearization.push_back(against);
                  }
                row.peak_ratio        = peak_i / std::max(peak_f, 1e-300);
                row.irdm_us           = 1e6 * step_seconds / n;
                row.centrifugal       = centrifugal / peak_contact;
                row.stable            = row.stable && row.energy_growth < 0.05;
                log << "  " << row.method << ": com " << row.com_error << ", angle "
                    << row.angle_error << " deg, force " << row.force_error << ", impulse "
                    << row.impulse_error << ", deformation " << row.deformation_error << ", IRDM "
                    << row.irdm_us << " us/step, FEM " << row.fem_ms << " ms/step" << std::endl;
                rows.push_back(row);
            };
            for (size_t r = 0; r < models.size(); ++r)
              if (!models[r].impact_study_only || k.in_study())
                {
                  FreeBodyInteraction irdm(models[r].model, fo);
                  run_method(irdm, models[r].method.c_str(), identity);
                }
            // The virtual-DOF model holds responses to walls only (no probe); the impact study
            // is of the modal routes.
            if (vdof && !probed && !k.in_study())
              {
                FreeBodyOptions vo  = fo; // the virtual DOFs hold no mode shapes
                vo.centrifugal      = false;
                vo.deformed_inertia = false;
                FreeBodyVirtualDofs irdm(*vdof, vo);
                run_method(irdm, vdof_method, vdof_order);
              }
          }

        // Stability: the rolling cat (spin_roll's start) for a long run of the runtime alone,
        // by each route; and free flight with no plane for 10 s.
        const auto roll_for_long = [&](auto &irdm, const char *method) {
            const Case roll   = rolling_case();
            double     lowest = 1e300;
            for (const auto &X : rest)
              lowest = std::min(lowest, X(2));
            const FreeBodyOptions fo;
            irdm.rigid().set_velocity(roll.velocity, roll.spin);
            PlaneTarget floor;
            floor.normal    = {0, 0, 1};
            floor.point     = {0, 0, lowest - roll.height};
            floor.penalty   = floor_penalty;
            EnergyWatch<std::decay_t<decltype(irdm)>> watch{irdm, fo.gravity};
            watch.start(roll.height);
            const unsigned steps = static_cast<unsigned>(std::lround(o.stability_seconds / tau));
            const unsigned trace_every = std::max(1u, static_cast<unsigned>(std::lround(0.1 / tau)));
            double growth = 0, turned = 0, seconds = 0, deepest = 0;
            unsigned failed = 0;
            Eigen::Matrix3d R_prev = Eigen::Matrix3d::Identity();
            // The surface (deformed, placed by the pose) at the trace's samples: how far its
            // lowest vertex is below the floor (a contact that holds keeps it near the
            // penalty's give).
            const unsigned      nv = irdm.deformation().n_vertices();
            std::vector<double> x(3 * static_cast<size_t>(nv));
            for (unsigned step = 1; step <= steps; ++step)
              {
                const auto t0 = Clock::now();
                failed += irdm.step(&floor, 1) ? 0 : 1;
                seconds += std::chrono::duration<double>(Clock::now() - t0).count();
                growth = std::max(growth, watch.growth());
                turned += angle_deg(irdm.rigid().rotation() * R_prev.transpose());
                R_prev = irdm.rigid().rotation();
                if (step % trace_every == 0)
                  {
                    int active = 0;
                    if constexpr (std::is_same_v<std::decay_t<decltype(irdm)>, FreeBodyInteraction>)
                      active = irdm.deformation().plane_result(0).active;
                    irdm.surface_positions(x.data());
                    double below = 0;
                    for (unsigned v = 0; v < nv; ++v)
                      below = std::max(below, floor.point[2] - x[3 * v + 2]);
                    deepest = std::max(deepest, below);
                    stability_csv << material_name(E) << ',' << method << ',' << step * tau << ','
                                  << watch.growth() << ','
                                  << irdm.deformation().elastic_energy() / watch.e_in << ','
                                  << turned << ',' << active << ',' << below << '\n';
                  }
              }
            stability << "| rolling, " << o.stability_seconds << " s | " << material_name(E) << " | "
                      << method << " | " << growth << " | " << turned << " | "
                      << watch.growth() << " | " << failed << " | " << 1e3 * deepest << " | "
                      << 1e6 * seconds / steps << " |\n";
            log << "validate-free: " << o.stability_seconds << " s rolling, " << method
                << ": largest energy gain " << growth << " of the energy brought in, turned "
                << turned << " deg, " << failed << " failed steps" << std::endl;
        };
        for (size_t r = 0; r < models.size() && floor_penalty > 0; ++r)
          if (!models[r].impact_study_only)
          {
            FreeBodyOptions fo;
            fo.centrifugal      = o.centrifugal;
            fo.deformed_inertia = o.deformed_inertia;
            FreeBodyInteraction irdm(models[r].model, fo);
            roll_for_long(irdm, models[r].method.c_str());
          }
        if (vdof && floor_penalty > 0)
          {
            FreeBodyVirtualDofs irdm(*vdof, FreeBodyOptions());
            roll_for_long(irdm, vdof_method);
          }
        // Free flight: no plane, 10 s, spinning about an axis off the principal ones. Without
        // the spin's coupling the deformation stays zero and the energy is the rigid
        // integrator's; with the centrifugal force alone the spin stretches the body, whose
        // strain energy is not taken from the spin (the gain it shows); with the deformed
        // inertia as well it is.
        for (const bool coupled : {false, true})
          {
            if (coupled && !o.centrifugal && !o.deformed_inertia)
              continue;
            FreeBodyOptions fo;
            fo.centrifugal      = coupled && o.centrifugal;
            fo.deformed_inertia = coupled && o.deformed_inertia;
            FreeBodyInteraction irdm(models.back().model, fo);
            const Eigen::Vector3d v0(0.3, -0.2, 1.0), w0(3, 8, -5);
            irdm.rigid().set_velocity(v0, w0);
            const Eigen::Vector3d p0 = irdm.rigid().state().linear_momentum,
                                  L0 = irdm.rigid().state().angular_momentum;
            EnergyWatch<std::decay_t<decltype(irdm)>> watch{irdm, fo.gravity};
            watch.start(0);
            const unsigned steps = static_cast<unsigned>(std::lround(10.0 / tau));
            double dp = 0, dL = 0, growth = 0;
            for (unsigned step = 1; step <= steps; ++step)
              {
                irdm.step(nullptr, 0);
                const Eigen::Vector3d p = p0 + mass * fo.gravity * (step * tau);
                dp     = std::max(dp, (irdm.rigid().state().linear_momentum - p).norm() / p0.norm());
                dL     = std::max(dL, (irdm.rigid().state().angular_momentum - L0).norm() / L0.norm());
                growth = std::max(growth, watch.growth());
              }
            const std::string what =
              !coupled ? ""
              : fo.centrifugal && fo.deformed_inertia ? ", with the centrifugal force and the deformed inertia"
              : fo.centrifugal ? ", with the centrifugal force"
                               : ", with the deformed inertia";
            stability << "| free flight, 10 s" << what << " | " << material_name(E) << " | "
                      << (coupled ? models.back().method : std::string("either (no contact)"))
                      << " | " << growth << " | | | 0 | | |\n";
            free_flight_lines.push_back(
              material_name(E) + what + ": linear momentum within " + format_g(dp) +
              " of p0 + m g t (relative to |p0|), angular momentum within " + format_g(dL) +
              " of L0, energy gain " + format_g(growth) + " of the initial kinetic energy, the "
              "deformation's energy " + format_g(irdm.deformation().elastic_energy()) + " J");
          }
      }

    std::ostringstream csv;
    csv << "case,material,method,com_error,angle_error_deg,force_error,impulse_error,"
           "deformation_error,irdm_us_per_step,fem_ms_per_step,stable\n";
    for (const Row &r : rows)
      {
        if (r.impact_speed > 0)
          continue; // impact.csv
        csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',';
        if (!r.fem_failed.empty())
          csv << "nan,nan,nan,nan,nan,nan,nan,fem_failed\n";
        else
          csv << r.com_error << ',' << r.angle_error << ',' << r.force_error << ','
              << r.impulse_error << ',' << r.deformation_error << ',' << r.irdm_us << ','
              << r.fem_ms << ',' << (r.stable ? "yes" : "no") << '\n';
      }
    // The first contact alone (first_contact.csv).
    std::ostringstream first_csv, first_md;
    first_csv << "case,material,method,start_s,end_s,force_error,impulse_error,deformation_error\n";
    for (const Row &r : rows)
      if (r.impact_speed == 0 && r.fem_failed.empty() && r.first_end > r.first_start)
        {
          first_csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',' << r.first_start
                    << ',' << r.first_end << ',' << r.first_force_error << ','
                    << r.first_impulse_error << ',' << r.first_deformation_error << '\n';
          first_md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method << " | "
                   << r.first_start << " to " << r.first_end << " | " << r.first_force_error
                   << " | " << r.first_impulse_error << " | " << r.first_deformation_error << " |\n";
        }
    write_text_file((fs::path(dir) / "first_contact.csv").string(), first_csv.str());
    // The truth's strains (truth_strain.csv).
    std::ostringstream strain_csv, strain_md;
    strain_csv << "case,material,impact_speed_m_s,start_s,end_s,first_largest_strain,"
                  "first_strained_volume_fraction,run_largest_strain\n";
    for (const StrainRow &r : strain_rows)
      {
        strain_csv << r.c << ',' << material_name(r.E) << ',' << r.impact_speed << ',' << r.start
                   << ',' << r.end << ',' << r.first_largest << ',' << r.first_fraction << ','
                   << r.run_largest << '\n';
        strain_md << "| " << r.c << " | " << material_name(r.E) << " | " << r.start << " to "
                  << r.end << " | " << r.first_largest << " | " << r.first_fraction << " | "
                  << r.run_largest << " |\n";
      }
    write_text_file((fs::path(dir) / "truth_strain.csv").string(), strain_csv.str());
    // Linearization and method apart (linearization.csv).
    std::ostringstream lin_csv, lin_md;
    lin_csv << "case,material,method,reference,start_s,end_s,fem_rotation_deg,first_force_error,"
               "first_impulse_error,first_deformation_error,com_error,angle_error_deg,force_error,"
               "impulse_error,deformation_error\n";
    for (const LinearizationRow &r : linearization)
      {
        if (r.impact_speed > 0)
          continue; // impact.csv
        lin_csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',' << r.reference << ','
                << r.start << ',' << r.end << ',' << r.rotation_deg << ',';
        lin_md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method << " | "
               << r.reference << " | " << r.start << " to " << r.end << " | " << r.rotation_deg
               << " | ";
        const RunErrors &e = r.errors;
        if (!r.failed.empty())
          {
            lin_csv << "nan,nan,nan,nan,nan,nan,nan,nan\n";
            lin_md << "the linear FEM failed: " << r.failed << " ||||||\n";
            continue;
          }
        lin_csv << e.window_force << ',' << e.window_impulse << ',' << e.window_deformation << ','
                << e.com << ',' << e.angle << ',' << e.force << ',' << e.impulse << ','
                << e.deformation << '\n';
        lin_md << e.window_force << " | " << e.window_impulse << " | " << e.window_deformation
               << " | " << e.com << " | " << e.angle << " | " << e.deformation << " |\n";
      }
    if (o.small_strain)
      write_text_file((fs::path(dir) / "linearization.csv").string(), lin_csv.str());
    // The impact study (impact.csv): every run against the truth, and the runtime against the
    // small-strain FEM, over the first contact, by speed and by speed over the bar wave speed
    // sqrt(E / rho).
    struct ImpactLine
    {
      std::string c, method, reference;
      double      E, v, start, end, force, impulse, deformation; // over the first contact
      double      run_force, run_impulse, run_deformation, run_angle;    // over the whole run
    };
    std::vector<ImpactLine> impact;
    for (const Row &r : rows)
      if (r.impact_speed > 0 && r.fem_failed.empty())
        impact.push_back({r.c, r.method, "fem_neo_hookean", r.E, r.impact_speed, r.first_start,
                          r.first_end, r.first_force_error, r.first_impulse_error,
                          r.first_deformation_error, r.force_error, r.impulse_error,
                          r.deformation_error, r.angle_error});
    for (const LinearizationRow &r : linearization)
      if (r.impact_speed > 0 && r.failed.empty())
        impact.push_back({r.c, r.method, r.reference, r.E, r.impact_speed, r.start, r.end,
                          r.errors.window_force, r.errors.window_impulse,
                          r.errors.window_deformation, r.errors.force, r.errors.impulse,
                          r.errors.deformation, r.errors.angle});
    std::stable_sort(impact.begin(), impact.end(), [](const ImpactLine &a, const ImpactLine &b) {
      return std::tie(a.E, a.v, a.reference) < std::tie(b.E, b.v, b.reference);
    });
    std::ostringstream impact_csv, impact_md;
    impact_csv << "case,material,speed_m_s,speed_over_wave_speed,method,reference,start_s,end_s,"
                  "first_force_error,first_impulse_error,first_deformation_error,force_error,"
                  "impulse_error,deformation_error,angle_error_deg\n";
    for (const ImpactLine &l : impact)
      {
        const double ratio = l.v / std::sqrt(l.E / base.density);
        impact_csv << l.c << ',' << material_name(l.E) << ',' << l.v << ',' << ratio << ','
                   << l.method << ',' << l.reference << ',' << l.start << ',' << l.end << ','
                   << l.force << ',' << l.impulse << ',' << l.deformation << ',' << l.run_force << ','
                   << l.run_impulse << ',' << l.run_deformation << ',' << l.run_angle << '\n';
        impact_md << "| " << material_name(l.E) << " | " << l.v << " | " << ratio << " | "
                  << l.method << " | " << l.reference << " | " << l.start << " to " << l.end
                  << " | " << l.force << " | " << l.impulse << " | " << l.deformation << " | "
                  << l.run_force << " | " << l.run_deformation << " | " << l.run_angle << " |\n";
      }
    if (!impact.empty())
      write_text_file((fs::path(dir) / "impact.csv").string(), impact_csv.str());
    std::ostringstream tri;
    tri << "a,b,c\n";
    for (const auto &t : triangles)
      tri << t[0] << ',' << t[1] << ',' << t[2] << '\n';
    write_text_file((fs::path(dir) / "free.csv").string(), csv.str());
    write_text_file((fs::path(dir) / "series.csv").string(), series.str());
    write_text_file((fs::path(dir) / "stability.csv").string(), stability_csv.str());
    write_text_file((fs::path(dir) / "frames.csv").string(), frames.str());
    write_text_file((fs::path(dir) / "triangles.csv").string(), tri.str());
    if (o.truth_check)
      write_text_file((fs::path(dir) / "truth.csv").string(), truth_csv.str());

    // Charts (matplotlib from Debian); the report stands without them.
    bool charts = false;
    if (!o.plot_script.empty())
      {
        const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir + "'";
        charts                = std::system(cmd.c_str()) == 0;
        if (!charts)
          log << "validate-free: the charts were not drawn (" << cmd << " failed)" << std::endl;
      }

    std::ostringstream fem_steps; // the truth's step per material
    for (size_t m = 0; m < o.materials.size(); ++m)
      {
        fem_steps << (m ? ", " : "") << base.time_step * 1e3 / fem_divisions_of(o, m) << " ms at "
                  << material_name(o.materials[m]);
      }
    std::ostringstream divisions;
    for (size_t m = 0; m < o.fem_divisions.size(); ++m)
      divisions << (m ? "," : "") << o.fem_divisions[m];
    std::ostringstream md;
    md << "# Free body against the nonlinear FEM (issue 14)\n\n"
       << report_stamp() << "\n\n"
       << "Written by `irdm validate-free" << (o.quick ? " --quick" : "")
       << " --fem-divisions " << divisions.str()
       << (o.reuse_models ? " --reuse-models" : "") << (o.truth_check ? " --truth-check" : "")
       << (o.surface_modes ? " --surface-modes " + std::to_string(o.surface_modes) : std::string())
       << (o.small_strain ? "" : " --no-small-strain")
       << (o.small_strain && !o.body_frame ? " --linear-law linear" : "")
       << (o.centrifugal ? " --centrifugal" : "")
       << (o.deformed_inertia ? " --deformed-inertia" : "") << "`. Body: `" << o.scene
       << "` (the cat, P1, fixed to nothing), Newmark average acceleration, tau = "
       << base.time_step * 1e3 << " ms, " << o.duration
       << " s per case (spin_roll 2 s), gravity 9.81 m/s^2 against the floor's normal. Truth: "
          "the nonlinear FEM on the same mesh (neo-Hookean, penalty planes, default penalty "
          "100 E / h) at its own step ("
       << fem_steps.str()
       << "; `--fem-divisions`), sampled at tau: at 2 kPa and 2 ms its energy grows "
          "(average-acceleration Newmark on large strains: 0.2 s after a 2 cm drop it had "
          "gained 0.47 J, where the runs at 1 and 0.5 ms had lost 0.14 J to damping and "
          "agreed; at 50 kPa the runs at 2, 1 and 0.5 ms all lose energy and agree), so the soft truth runs "
          "finer. Its impulse is summed at its own step; `fem_ms_per_step` is its cost per "
          "step of tau (the same simulated time as one runtime step). IRDM: `FreeBodyInteraction` (rigid body + the modal deformation of the "
          "free-body model, every elastic mode in the force loop, "
       << (o.surface_modes == 0 ? std::string("every mode") : std::to_string(o.surface_modes))
       << " in the surface" << (o.surface_modes == 0 ? " (until 2026-11-25, 100: the impact study below measures what that truncation costs)" : "")
       << "), many-vertex contact with the FEM's penalty, "
          "each vertex's stiffness the penalty times its lumped area, as the FEM's P1 contact "
          "(integrated at the face vertices) weighs it: the same contact discretization, on "
          "the linearized surface. (Before 2026-11-25 every vertex had the mean area's "
          "stiffness; the 2 cm drop at 50 kPa moved by less than 1 % of its errors.) Method and "
          "discretization are not separated here: the FEM and the model share the P1 mesh, so "
          "every error below is the method's (linear elasticity in the body frame against "
          "neo-Hookean, contact on the linearized surface), not the mesh's.\n\n"
       << "Two routes (`irdm precompute --free-route`, docs/model-format.md):\n\n"
          "- `route1_rigid_fit`, the seed's: the free body's whole recorded response (rigid "
          "modes included) minus, at every sample, its best rigid fit by least squares over the "
          "surface vertices with uniform weights. Uniform, because that is the seed's fit over "
          "corresponding surface nodes and the surface is what is recorded; the linear FEM's "
          "rigid motions are infinitesimal, so the best fit is the linear projection onto the six "
          "rigid fields (exact on the linear FEM, where a finite-rotation Kabsch fit would "
          "misread the linearized rotation as stretch). Test: "
          "`FreeBody.RigidFitRouteIsTheRecordedResponseMinusItsBestFit` (recorded FEM minus fit "
          "= H to 1e-10). The fit is not mass-orthogonal: the deformation keeps some momentum, "
          "which the rigid body then does not carry.\n"
          "- `route2_modal`: the six rigid-body modes dropped, mass-orthogonal (the best fit "
          "with the consistent mass over every node, to first order); the deformation carries no "
          "momentum.\n";
    if (o.force_modes > 0)
      md << "- `route1_rigid_fit_k" << o.force_modes << "` and `route2_modal_k" << o.force_modes
         << "`: each route's model with only its lowest " << o.force_modes
         << " modes in the force loop and the rest quasi-static (their static compliance, "
            "through route 1's load shapes for route 1, joins the feed-through; "
            "docs/compression.md): the cheaper step, and its error beside the full model's.\n";
    if (o.vdof_subdivisions >= 0)
      md << "- `vdof_rigid_fit`, the seed's virtual DOFs (seed 001) of the free body: `irdm "
            "precompute-vdof` on it (icosahedron subdivided "
         << o.vdof_subdivisions << " times, T = " << o.vdof_length
         << " samples): one nonlinear-FEM wall hit per orientation, the recorded surface less, "
            "at every sample, its rigid part (the centre of mass's translation, the best "
            "rotation about it over the surface vertices). At run time "
            "(`FreeBodyVirtualDofs`) one wall force per plane, solved through the virtual "
            "DOFs' feed-through, the rigid body's step compliance and the precompute's penalty "
            "wall in series, acting at the mapped virtual DOF's band centroid (nearest "
            "mapping). It takes no probe (it holds responses to walls only), so it has no "
            "`probe_push` row.\n";
    md << "\nCase `probe_push`: the cat resting 1 mm above the floor, pushed at its head (the "
          "surface vertex farthest along +x above the centre of mass) by a known force of "
          "(-3, 0, -2) N for 0.2 s: a vertex force in the FEM, a `PointForce` in the runtime "
          "(irdm/free_body.h), which joins the contact forces in the rigid body's force and "
          "torque and the deformation's force history.\n\n"
          "What each includes of the body's own motion: gravity and the inertia of the body's "
          "linear and angular acceleration are rigid fields, M-orthogonal to route 2's elastic "
          "modes, so they drive no deformation (exact for linear elasticity); route 1's "
          "deformation is route 2's minus a rigid field, so the same holds. The spin's "
          "centrifugal force -M (w x (w x r)) is not rigid: "
       << (o.centrifugal
             ? "both routes take it into the deformation's force history (FreeBodyOptions::"
               "centrifugal, the step's predicted spin against the model's "
               "/modes/centrifugal_load; test FreeBodyRuntime.SpinStretchesTheBodyAsTheNonlinear"
               "FemDoes), on the force loop's modes (with K = 300 the modes beyond K leave it "
               "out); the virtual DOFs leave it out. Left out everywhere: the Coriolis forces "
               "-2 M w x v. "
             : "left out here, as are the Coriolis forces -2 M w x v (`--centrifugal` takes it "
               "in for the modal routes: FreeBodyOptions::centrifugal, test FreeBodyRuntime."
               "SpinStretchesTheBodyAsTheNonlinearFemDoes). ")
       << (o.deformed_inertia
             ? "The modal routes' rigid body has the deformed body's inertia, I0 + dI(u) to "
               "first order in the deformation, at every step's start (FreeBodyOptions::"
               "deformed_inertia; tests FreeBodyRuntime.SpinStretchesTheBodyAsTheNonlinearFemDoes "
               "and RigidBody.NewInertiaKeepsTheAngularMomentum): the angular momentum is kept, so the spin changes as the "
               "body is pressed in or stretched. "
             : "The rigid body's inertia is the undeformed body's (`--deformed-inertia` takes "
               "its change with the deformation in). ")
       << "The column `centrifugal / contact` measures the centrifugal load's size.\n\n"
       << "RunErrors: centre of mass, the largest distance between the two paths over the run, "
          "relative to the distance the FEM's centre travelled; orientation, the largest angle "
          "between the two surfaces' best-fit rotations (Kabsch, uniform weights over the "
          "surface vertices, the same estimator on both); plane force, relative L2 of the total "
          "plane force over the run, and the total impulse's relative error; deformation, "
          "relative RMS of the surface in its best-fit frame. Stable: every step solved, finite, "
          "and the runtime's energy (rigid, elastic, gravity) never above its start by 5 % of the "
          "energy the scene brings in (initial kinetic energy plus weight times drop height, plus "
          "the size of a probe's work, which is first taken off the energy).\n\n"
       << "| case | material | method | com | angle (deg) | force | impulse | peak IRDM/FEM | "
          "deformation | FEM rotation, largest / turned (deg) | centrifugal / contact | IRDM "
          "us/step | FEM ms/step | stable |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Row &r : rows)
      if (r.impact_speed > 0)
        continue; // the impact study's table
      else if (!r.fem_failed.empty())
        md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method
           << " | the FEM failed: " << r.fem_failed << " ||||||||||\n";
      else
        md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method << " | "
           << r.com_error << " | " << r.angle_error << " | " << r.force_error << " | "
           << r.impulse_error << " | " << r.peak_ratio << " | " << r.deformation_error << " | "
           << r.rotation_deg << " / " << r.turned_deg << " | " << r.centrifugal << " | "
           << r.irdm_us << " | " << r.fem_ms << " | " << (r.stable ? "yes" : "no") << " |\n";
    md << "\n\"centrifugal / contact\": the largest centrifugal load of the body's spin (m w^2 "
          "times its radius of gyration) over the largest plane force (at least its weight): "
          "the size of what the runtime leaves out of the deformation (irdm/free_body.h). "
          "\"turned\": the FEM surface's best-fit rotation summed step by step.\n\n"
       << "## The first contact alone\n\nThe same measures over the first contact only: "
          "from the FEM's first step with a plane force to the first step after it that begins "
          "10 ms without one, or the run's end (a foot that lifts for a step while the body "
          "still presses on does not end it; until 2026-11-25 the window ended at the first "
          "step without a force). Later bounces start from states that have already parted, "
          "so over the whole run the errors above also measure how far the paths diverged; "
          "over the first contact they do not, and they are linear elasticity's own error "
          "plus the method's, which the next sections measure apart (first_contact.csv).\n\n"
          "| case | material | method | window (s) | force | impulse | deformation |\n"
          "|---|---|---|---|---|---|---|\n"
       << first_md.str() << "\n"
       << "## How far the truth is from small strain\n\nThe nonlinear FEM's largest principal "
          "stretch departure max_i |lambda_i - 1| over its quadrature points (lambda_i^2 the "
          "eigenvalues of F^T F: objective, so a spinning body's turn adds nothing), and the "
          "fraction of the body's volume where it passes 0.1, at their largest over the first "
          "contact, and the largest over the whole run (truth_strain.csv). Linear elasticity "
          "is the first-order theory in the strain, so its own error grows with the strain "
          "(the impact study below measures it against the speed). On the P1 mesh the largest is one "
          "element's, and at a sharp edge under contact it grows with refinement; the volume "
          "fraction does not depend on one element.\n\n"
          "| case | material | first contact (s) | largest strain | volume past 0.1 | largest "
          "strain, whole run |\n|---|---|---|---|---|---|\n"
       << strain_md.str() << "\n"
       << (o.small_strain
             ? "## Linearization and method apart\n\nThe same FEM (solver, mesh, step, penalty "
               "contact) with a linear law in place of neo-Hookean, " +
                 std::string(o.body_frame
                   ? "the small-strain law in the body's frame (`material.law` "
                     "\"linear_body_frame\": P = R (lambda tr(e) I + 2 mu e), e = sym(R^T F) - I, "
                     "R the rotation of the body's best rigid fit over its mesh vertices weighed "
                     "by their lumped volume, held over each step at the step's predicted "
                     "motion): linear elasticity in a frame that follows the body, what both "
                     "routes linearize (reference_fem/include/reference_fem/scene.h). "
                     "`fem_linear_body_frame` against the truth (`fem_neo_hookean`) is what linear "
                     "elasticity itself misses, which any linear method inherits; each runtime "
                     "method against `fem_linear_body_frame` is the method's own error (the "
                     "rigid/elastic split, the rigid integrator, what is left out of the spin: "
                     "the linear FEM keeps its centrifugal and Coriolis forces). Until "
                     "2026-11-26 this was the plain small-strain law, which is not objective (a "
                     "spin's velocity field w x X strains it not at all, so its body swells "
                     "instead of turning, and its deformation did not turn with the body): it "
                     "could not run spin_roll, and on the 2 cm drop at 50 kPa route 2's "
                     "deformation error over the first contact was 10.5 % against it, 8.2 % "
                     "against the body-frame law (`--linear-law linear` runs it). `truth turned` states the truth's largest rotation up to the "
                     "first contact's end (linearization.csv).\n\n"
                   : "the plain small-strain law (`material.law` \"linear\": sigma = lambda "
                     "tr(eps) I + 2 mu eps, eps the symmetric displacement gradient): "
                     "`fem_small_strain` against the truth (`fem_neo_hookean`) is what linear "
                     "elasticity itself misses, and each runtime method against it the method's "
                     "own error, as far as the body has not turned: the law is not objective (a "
                     "spin's velocity field strains it not at all, so the body swells instead of "
                     "turning), so spin_roll is not run, and `truth turned` states the truth's "
                     "largest rotation up to the first contact's end (linearization.csv).\n\n") +
               "| case | material | run | against | first contact (s) | truth turned (deg) | "
               "force | impulse | deformation | whole run: com | angle (deg) | deformation |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|\n" + lin_md.str() + "\n"
             : std::string())
       << (o.truth_check
             ? "## How well the truth is determined\n\nThe nonlinear FEM at half its step "
               "(tau / 2M) against the FEM at its step (tau / M, above), by the same measures "
               "as the table above (truth.csv). Where the FEM's own change with its step is as "
               "large as the runtime's error, the truth does not decide the runtime's accuracy "
               "to better than that. The last column is the half-step run's cost per step of "
               "tau.\n\n| case | material | com | angle "
               "(deg) | force | impulse | deformation | FEM tau / 2M ms per tau |\n"
               "|---|---|---|---|---|---|---|---|\n" + truth_md.str() + "\n"
             : std::string())
       << (impact.empty()
             ? std::string()
             : "## Where linear elasticity stops holding: the first contact against the impact "
               "speed\n\nThe upright cat 1 mm above the floor, moving toward it at v, gravity "
               "off, 0.3 s (cases `impact_<v>`, impact.csv; `--impact-speeds`); each material at "
               "its truth's step. Linear elasticity with a linear penalty is positively "
               "homogeneous: its response scales with v, so a linear method's relative error "
               "against a linear truth is the same at every speed, while linear against "
               "nonlinear elasticity shrinks with the strain, about v / c (c = sqrt(E / rho), the "
               "bar wave speed). `" + std::string(linear_fem) + "` against `fem_neo_hookean` is that "
               "linearization; the runtime against `" + linear_fem + "` is the method's own error "
               "(at 2 kPa it includes the runtime's step, tau, against the FEM's finer one). "
               "`route2_modal_s" + std::to_string(o.study_surface_modes) + "` is route 2 with "
               "only its lowest " + std::to_string(o.study_surface_modes) + " modes in the "
               "surface update (the others' static correction for the step's force added), "
               "where `route2_modal` has every mode: what that truncation of the surface costs. "
               "Measures over the first contact (the FEM's first step with a plane force to the "
               "first that begins 10 ms without one, or the run's end). Over the whole run "
               "(the last three columns) the body has turned" +
                 std::string(o.body_frame
                   ? ", and later contacts start from states that have parted" 
                   : ", and the small-strain FEM does not turn its deformation with the body (an "
                     "error of the first order in the angle, which grows with v): there the "
                     "figures against `fem_small_strain` measure that FEM as much as the runtime") +
                 std::string(charts ? "; impact.png plots the deformation error against v / c" : "") +
                 ".\n\n| material | v (m/s) | v / c | run | against | first contact (s) | force "
                 "| impulse | deformation | whole run: force | deformation | angle (deg) |\n"
                 "|---|---|---|---|---|---|---|---|---|---|---|---|\n" +
                 impact_md.str() + "\n" +
                 (charts ? "![impact](impact.png)\n\n" : ""))
       << "## Fig. 6: the floor force of the rolling cat\n\n"
       << (charts ? "![floor force](fig6.png)\n\nThe floor force along its normal against time, "
                    "spin_roll (dropped 2 cm spinning at 8 rad/s), the FEM and both routes "
                    "(series.csv).\n\n![frames](frames.png)\n\nThe rolling cat, FEM and both "
                    "routes side by side at six times (frames.csv).\n\n"
                  : "(charts not drawn: series.csv and frames.csv hold the data)\n\n")
       << "## Stability: the runtime alone\n\n"
          "The rolling cat's start (spin_roll) run for " << o.stability_seconds
       << " s by each route on the floor, and free flight with no plane for 10 s (spinning at "
          "(3, 8, -5) rad/s, thrown at (0.3, -0.2, 1) m/s). Energy gain: the largest E(t) - E(0) "
          "over the energy brought in; final: at the end. `stability.csv` traces the rolls every "
          "0.1 s: energy gain, the deformation's energy over the energy brought in (0 for the "
          "virtual DOFs, whose energy is not known), turned angle, vertices the floor pushes (0 "
          "for the virtual DOFs), and how far the surface's lowest vertex (deformed, placed by "
          "the pose) is below the floor; `below floor` is the deepest of those samples (a "
          "contact that holds keeps it near the penalty's give).\n\n"
          "| run | material | method | largest energy gain | turned (deg) | final | failed steps "
          "| below floor (mm) | us/step |\n|---|---|---|---|---|---|---|---|---|\n"
       << stability.str() << "\n"
       << (charts ? "![energy gain over time](stability.png)\n\n" : "") << "Free flight:\n\n";
    for (const auto &line : free_flight_lines)
      md << "- " << line << "\n";
    write_text_file((fs::path(dir) / "report.md").string(), md.str());
    log << "validate-free: wrote " << dir << "/free.csv, series.csv, stability.csv, report.md"
        << std::endl;
  }
} // namespace irdm::validation
