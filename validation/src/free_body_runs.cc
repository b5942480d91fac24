// The free-body study's runner (free_body_runs.h): each material's models, and each case
// through the nonlinear FEM (the truth), the linear FEM and every runtime method.
#include "free_body_runs.h"
#include "metrics.h"
#include "scene_runs.h"
#include "surface_transfer.h"

#include <irdm_common/error.h>
#include <irdm_common/format.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/mesh.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/virtual_dof.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace fs = std::filesystem;

namespace irdm::validation::free_body
{
  std::string
  AngularMomentumBalance::text() const
  {
    std::ostringstream out;
    out << "changed by " << (last - first).norm() << " kg m^2/s, the torque's impulse "
        << impulse.norm() << " N m s, their difference " << (last - first - impulse).norm();
    return out.str();
  }

  namespace
  {
    using Clock = std::chrono::steady_clock;

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

    // A FEM run at tau / M as Samples at tau (sample_at_tau), its surface read at the
    // comparison's vertices (`node_tags`, rest positions `rest`), or, for a run on another mesh
    // of the body, by `transfer` at their closest points; `x`, when given, receives the
    // surfaces.
    Samples
    fem_samples(fem::RunResult &r, const unsigned M, const double tau,
                const std::vector<fem::RigidPlane> &planes, const std::vector<Eigen::Vector3d> &rest,
                const std::vector<long long> &node_tags, const Eigen::Vector3d &c0,
                std::vector<std::vector<Eigen::Vector3d>> *x = nullptr,
                const SurfaceTransfer *transfer = nullptr)
    {
      std::vector<Eigen::Vector3d> impulse = sample_at_tau(r, M, tau);
      const unsigned               n       = static_cast<unsigned>(impulse.size() - 1);
      Samples                      s(n);
      s.impulse = std::move(impulse);
      std::map<long long, unsigned> at;
      for (unsigned i = 0; !transfer && i < r.surface.node_tags.size(); ++i)
        at[r.surface.node_tags[i]] = i;
      std::vector<Eigen::Vector3d> xs(rest.size());
      if (x)
        x->assign(n + 1, std::vector<Eigen::Vector3d>(rest.size()));
      for (unsigned step = 1; step <= n; ++step)
        {
          for (const auto &pl : planes)
            s.force[step] += vec(r.plane_force.at(pl.name)[step]);
          s.com[step] = c0 + vec(r.center_of_mass_displacement[step]);
          if (transfer)
            {
              const std::vector<double> u = transferred(*transfer, r.surface_displacement[step]);
              for (size_t v = 0; v < rest.size(); ++v)
                xs[v] = rest[v] + Eigen::Vector3d(u[3 * v], u[3 * v + 1], u[3 * v + 2]);
            }
          else
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

    // The two routes (reference_fem/impulse_response.h, FreeBodyRoute).
    struct Route
    {
      const char        *method; // free.csv's method column
      fem::FreeBodyRoute route;
      const char        *file_suffix;
    };
    constexpr Route routes[] = {{"route1_rigid_fit", fem::FreeBodyRoute::rigid_fit, "_rigid_fit"},
                                {"route2_modal", fem::FreeBodyRoute::modal, ""}};

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


    /// The body in material E: the scene's text with its modulus replaced, so that the model
    /// records the scene it was made from.
    fem::Scene
    body_of(const FreeBodyValidationOptions &o, const std::string &base_text, const double E)
    {
      std::ostringstream e;
      e << "\"youngs_modulus_Pa\": " << E;
      std::string  text = base_text;
      const size_t key  = text.find("\"youngs_modulus_Pa\"");
      if (key == std::string::npos)
        throw InputError("validate-free: the scene '" + o.scene + "' gives no youngs_modulus_Pa");
      const size_t colon = text.find(':', key), end = text.find_first_of(",}", colon);
      text.replace(key, end - key, e.str());
      return fem::parse_scene(text, fs::path(o.scene).parent_path().string(), o.scene);
    }

    /// The seed's virtual DOFs of the free body (route 1 with the nonlinear FEM's wall hits),
    /// and where each compared vertex is on its surface.
    void
    prepare_virtual_dofs(Material &m, std::ostream &log)
    {
      const auto &o = m.o;
      const std::string file =
        (fs::path(o.model_dir) / ("free_cat_" + material_name(m.E) + "_vdof.h5")).string();
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
          fem::precompute_virtual_dofs(m.body, vo);
        }
      m.vdof = load_virtual_dof_model(file, m.tau);
      if (!m.vdof->free_body)
        throw InputError("validate-free: '" + file + "' is not a free body's model");
      std::map<long long, unsigned> at;
      for (unsigned i = 0; i < m.vdof->node_tags.size(); ++i)
        at[m.vdof->node_tags[i]] = i;
      m.vdof_order.resize(m.rest.size());
      for (size_t v = 0; v < m.rest.size(); ++v)
        {
          const auto it = at.find(m.node_tags[v]);
          if (it == at.end())
            throw InputError("validate-free: the virtual-DOF model's surface lacks a vertex "
                             "of the modal model's");
          m.vdof_order[v] = it->second;
        }
    }

    /// One case of one material: its planes, probe, the truth's run and its samples.
    struct CaseRun
    {
      const Case                  &k;
      std::vector<fem::RigidPlane> planes;
      bool                         probed       = false;
      unsigned                     probe_vertex = 0;
      fem::History                 probe_history{};
      fem::Scene                   s{}; // the truth's scene
      fem::RunResult               fem_r{};
      double                       fem_seconds = 0;
      std::optional<Samples>       truth{};
      std::vector<std::vector<Eigen::Vector3d>> fem_x{}; // the truth's surface per step
      unsigned                     n = 0, first_begin = 0, first_end = 0; // steps of tau
      std::optional<Samples>       small_strain{}; // the linear FEM's
      std::optional<Samples>       converged{};    // the converged truth's, where it ran
      double                       window_rotation = 0; // the truth's largest, to first_end
    };

    /// The planes (the floor below the body's lowest point along `up`, and a wall), the probe's
    /// vertex and force history (the same for the FEM and the runtime), and the truth's scene.
    CaseRun
    setup_case(const Material &m, const Case &k)
    {
      CaseRun c{k, std::vector<fem::RigidPlane>(1)};
      double  lowest = 1e300, farthest_x = -1e300;
      for (const auto &X : m.rest)
        lowest = std::min(lowest, k.up.dot(X)), farthest_x = std::max(farthest_x, X(0));
      c.planes[0].name     = "floor";
      c.planes[0].normal   = arr(k.up);
      c.planes[0].position = fem::History::constant(arr((lowest - k.height) * k.up));
      if (k.wall)
        {
          fem::RigidPlane w;
          w.name     = "wall";
          w.normal   = {-1, 0, 0};
          w.position = fem::History::constant({farthest_x + 0.02, 0, 0});
          c.planes.push_back(w);
        }
      c.probed = k.probe_force.norm() > 0;
      if (c.probed)
        {
          double best = -1e300;
          for (size_t v = 0; v < m.rest.size(); ++v)
            if (m.output_input_index[v] >= 0 && m.rest[v](2) > m.c0(2) && m.rest[v](0) > best)
              best = m.rest[v](0), c.probe_vertex = static_cast<unsigned>(v);
          c.probe_history.times  = {0, k.probe_seconds, k.probe_seconds + m.tau};
          c.probe_history.values = {arr(k.probe_force), arr(k.probe_force), {0, 0, 0}};
        }
      fem::Scene &s              = c.s;
      s                          = m.body;
      s.kinematics               = fem::Kinematics::nonlinear;
      s.gravity_enabled          = k.gravity;
      s.gravity                  = arr(-9.81 * k.up);
      s.initial_velocity         = arr(k.velocity);
      s.initial_angular_velocity = arr(k.spin);
      s.planes                   = c.planes;
      s.duration                 = k.duration > 0 ? k.duration : m.o.duration;
      s.time_step                = m.tau / m.M; // the truth's own step; sampled at tau
      s.vertex_forces.clear();
      if (c.probed)
        {
          fem::VertexForce probe;
          probe.name            = "probe";
          probe.vertex.node_tag = m.node_tags[c.probe_vertex];
          probe.force           = c.probe_history;
          s.vertex_forces.push_back(probe);
        }
      s.outputs      = fem::Scene::Outputs();
      s.outputs.hdf5 = s.outputs.csv = false;
      s.outputs.surface              = true;
      return c;
    }

    /// Every method the case runs (the virtual DOFs take no probe; the impact study is of the
    /// modal routes; the reduced models run every case).
    std::vector<std::string>
    methods_of(const Material &m, const CaseRun &c)
    {
      std::vector<std::string> methods;
      for (const NamedModel &nm : m.models)
        if (!nm.impact_study_only || c.k.in_study())
          methods.push_back(nm.method);
      if (m.vdof && !c.probed && !c.k.in_study())
        methods.push_back(vdof_method);
      for (const ReducedModelOfBody &r : m.reduced)
        methods.push_back(r.method);
      return methods;
    }

    /// The first contact's steps [first_begin, first_end): from the FEM's first step with a
    /// plane force to the first after it that begins 10 ms without any (the run's end if it
    /// stays): a foot that leaves the floor for a step and lands again, while the body still
    /// presses on, does not end it.
    void
    find_first_contact(CaseRun &c, const double tau)
    {
      const unsigned n = c.n;
      c.first_begin = c.first_end = n + 1;
      const unsigned quiet = std::max(1u, static_cast<unsigned>(std::lround(0.01 / tau)));
      for (unsigned step = 1, free_steps = 0; step <= n; ++step)
        {
          const bool touching = c.truth->force[step].norm() > 0;
          if (c.first_begin > n)
            c.first_begin = touching ? step : c.first_begin;
          else if (touching)
            free_steps = 0;
          else if (++free_steps == quiet || step == n)
            {
              c.first_end = step + 1 - free_steps;
              break;
            }
        }
      for (unsigned step = 1; step < std::min(c.first_end, n + 1); ++step)
        c.window_rotation = std::max(c.window_rotation, angle_deg(c.truth->fit[step].rotation));
    }

    /// The truth's largest strain over the first contact and the run (truth_strain.csv).
    StrainRow
    strain_row(const Material &m, const CaseRun &c)
    {
      StrainRow sr;
      sr.c = c.k.name, sr.E = m.E, sr.impact_speed = c.k.impact_speed;
      sr.start = (c.first_begin - 1) * m.tau;
      sr.end   = (std::min(c.first_end, c.n + 1) - 1) * m.tau;
      const auto &r = c.fem_r;
      for (size_t i = 0; i < r.largest_strain.size() && i < r.time.size(); ++i)
        {
          sr.run_largest = std::max(sr.run_largest, r.largest_strain[i]);
          if (c.first_begin <= c.n && r.time[i] >= sr.start - 1e-9 * m.tau &&
              r.time[i] <= sr.end + 1e-9 * m.tau)
            {
              sr.first_largest  = std::max(sr.first_largest, r.largest_strain[i]);
              sr.first_fraction = std::max(sr.first_fraction, r.strained_volume_fraction[i]);
            }
        }
      return sr;
    }

    /// The truth: the nonlinear FEM at tau / M, sampled at tau. When it fails (Newton at a
    /// large, fast deformation) every method's row says so and false is returned.
    bool
    run_truth(Material &m, CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      const auto t_fem = Clock::now();
      try
        {
          c.fem_r = fem::NonlinearElasticity(c.s).run();
        }
      catch (const std::exception &e)
        {
          log << "  the FEM failed: " << e.what() << std::endl;
          for (const std::string &method : methods_of(m, c))
            {
              Row row;
              row.c = c.k.name, row.method = method, row.E = m.E, row.fem_failed = e.what();
              row.impact_speed = c.k.impact_speed;
              study.rows.push_back(row);
            }
          return false;
        }
      c.fem_seconds = std::chrono::duration<double>(Clock::now() - t_fem).count();
      const auto &r = c.fem_r;
      if (r.cut_steps > 0)
        log << "  the FEM cut back " << r.cut_steps << " of its " << r.n_steps
            << " steps (Newton failed at the full step; shortest " << r.smallest_step << " s)"
            << std::endl;
      log << "  the FEM's energy rose at most " << r.energy_rise / r.energy_scale
          << " of its scale above its start" << (c.probed ? " (the probe's work included)" : "")
          << std::endl;
      m.floor_penalty = r.plane_penalty.at("floor");
      c.truth = fem_samples(c.fem_r, m.M, m.tau, c.planes, m.rest, m.node_tags, m.c0, &c.fem_x);
      c.n     = c.truth->steps();
      find_first_contact(c, m.tau);
      const StrainRow sr = strain_row(m, c);
      study.strain.push_back(sr);
      log << "  the FEM's largest strain " << sr.first_largest << " over the first contact ("
          << sr.first_fraction << " of the volume past 0.1), " << sr.run_largest
          << " over the run" << std::endl;
      return true;
    }

    /// The FEM at half the step against the FEM at tau, at tau's sample times and by the same
    /// measures as the runtime's rows.
    void
    run_truth_check(const Material &m, const CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      fem::Scene half = c.s;
      half.time_step  = c.s.time_step / 2;
      log << "  the FEM at tau / 2M (truth check)" << std::endl;
      TruthRow   row{c.k.name, m.E};
      const auto t_half = Clock::now();
      try
        {
          fem::RunResult h = fem::NonlinearElasticity(half).run();
          row.half_ms = 1e3 * std::chrono::duration<double>(Clock::now() - t_half).count() / c.n;
          row.errors  = compare(*c.truth, fem_samples(h, 2 * m.M, m.tau, c.planes, m.rest, m.node_tags, m.c0),
                                m.c0, c.first_begin, c.first_end);
          const RunErrors &he = row.errors;
          log << "  the FEM at tau / 2M against tau / M: com " << he.com << ", angle " << he.angle
              << " deg, force " << he.force << ", impulse " << he.impulse << ", deformation "
              << he.deformation << std::endl;
        }
      catch (const std::exception &e)
        {
          log << "  the FEM at tau / 2M failed: " << e.what() << std::endl;
          row.failed = e.what();
        }
      study.truth.push_back(row);
    }

    LinearizationRow
    linearization_row(const Material &m, const CaseRun &c, const std::string &method,
                      const char *reference)
    {
      LinearizationRow row;
      row.c = c.k.name, row.method = method, row.reference = reference, row.E = m.E;
      row.start        = (c.first_begin - 1) * m.tau;
      row.end          = (std::min(c.first_end, c.n + 1) - 1) * m.tau;
      row.rotation_deg = c.window_rotation;
      row.impact_speed = c.k.impact_speed;
      return row;
    }

    const char *
    linear_fem_name(const FreeBodyValidationOptions &o)
    {
      return o.body_frame ? "fem_linear_body_frame" : "fem_small_strain";
    }

    /// The FEM on scene s, sampled at tau as the truth is (s at the truth's step over
    /// `refined`, so every M * refined of its steps); ms: its cost per step of tau (wall time,
    /// setup included, as the truth's).
    Samples
    run_sampled(const Material &m, const CaseRun &c, const fem::Scene &s, double &ms,
                const unsigned refined = 1)
    {
      const auto     t0 = Clock::now();
      fem::RunResult r  = fem::NonlinearElasticity(s).run();
      ms = 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / c.n;
      return fem_samples(r, refined * m.M, m.tau, c.planes, m.rest, m.node_tags, m.c0);
    }

    /// A run's samples against the converged truth, where it ran (linearization.csv).
    void
    against_converged(const Material &m, const CaseRun &c, const std::string &method,
                      const Samples &run, FreeStudy &study)
    {
      if (!c.converged)
        return;
      LinearizationRow row = linearization_row(m, c, method, converged_truth_name(m.o).c_str());
      row.errors           = compare(*c.converged, run, m.c0, c.first_begin, c.first_end);
      study.linearization.push_back(row);
    }

    /// The planes of scene s moved onto the body of another mesh: each by the two bodies'
    /// difference in reach along its normal (the nearest vertex's n . X), so that a drop falls
    /// the same height onto it.
    void
    planes_onto_mesh(fem::Scene &s, const std::string &mesh_file)
    {
      const fem::TetMesh from = fem::read_gmsh(s.mesh_file), to = fem::read_gmsh(mesh_file);
      const auto reach = [](const fem::TetMesh &mesh, const Eigen::Vector3d &n) {
        double h = INFINITY;
        for (const auto &X : mesh.vertices)
          h = std::min(h, n.dot(vec(X)));
        return h;
      };
      for (fem::RigidPlane &plane : s.planes)
        {
          const Eigen::Vector3d n     = vec(plane.normal);
          const double          shift = reach(to, n) - reach(from, n);
          for (auto &point : plane.position.values)
            for (int d = 0; d < 3; ++d)
              point[d] += shift * n(d);
        }
      s.mesh_file = mesh_file;
    }

    /// One step of a run in series.csv (not for the impact study's cases).
    void
    series_row(FreeStudy &study, const Material &m, const CaseRun &c, const std::string &method,
               const unsigned step, const Samples &run)
    {
      if (c.k.in_study())
        return;
      const RigidFit &ff = c.truth->fit[step], &fi = run.fit[step];
      double          d2 = 0, dd2 = 0;
      for (size_t v = 0; v < m.rest.size(); ++v)
        d2 += ff.deformation[v].squaredNorm(), dd2 += (ff.deformation[v] - fi.deformation[v]).squaredNorm();
      study.series << c.k.name << ',' << material_name(m.E) << ',' << method << ',' << step * m.tau
                   << ',' << c.truth->force[step].dot(c.k.up) << ',' << run.force[step].dot(c.k.up)
                   << ',' << c.truth->com[step](2) << ',' << run.com[step](2) << ','
                   << angle_deg(ff.rotation) << ',' << angle_deg(fi.rotation) << ','
                   << std::sqrt(d2 / m.rest.size()) << ',' << std::sqrt(dd2 / m.rest.size()) << '\n';
    }

    /// The nonlinear FEM of case c with P<converged_degree> elements on mesh_file (empty: the
    /// scene's own mesh, so the same surface vertices; else read at the closest points), sampled
    /// as the truth is; ms: its cost per step of tau.
    Samples
    truth_on_mesh(const Material &m, const CaseRun &c, const std::string &mesh_file, double &ms,
                  std::ostream &log)
    {
      fem::Scene s = c.s;
      s.fe_degree  = m.o.converged_degree;
      if (!mesh_file.empty())
        planes_onto_mesh(s, mesh_file);
      const auto     t0 = Clock::now();
      fem::RunResult r  = fem::NonlinearElasticity(s).run();
      ms = 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / c.n;
      std::optional<SurfaceTransfer> transfer;
      if (!mesh_file.empty())
        {
          transfer = surface_transfer(r.surface.coordinates, r.surface.triangles, m.rest);
          log << "  its surface at most " << 1e3 * transfer->gap << " mm from the body's vertices"
              << std::endl;
        }
      return fem_samples(r, m.M, m.tau, c.planes, m.rest, m.node_tags, m.c0, nullptr,
                         transfer ? &*transfer : nullptr);
    }

    /// The converged truth (FreeBodyValidationOptions::converged_degree on the same mesh or on
    /// converged_mesh), and the P1 truth against it: the truth's own discretization error. Then
    /// each converged_check_meshes' truth against it: how far the converged truth is from the
    /// next coarser ones, so whether it is converged.
    void
    run_converged_truth(const Material &m, CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      const auto &o = m.o;
      if (o.converged_degree == 0 ||
          std::find(o.converged_cases.begin(), o.converged_cases.end(), c.k.name) == o.converged_cases.end())
        return;
      const std::string name = converged_truth_name(o);
      if (!o.converged_mesh.empty() && c.probed)
        {
          log << "  " << name << " not run: the probe's vertex is this mesh's" << std::endl;
          return;
        }
      log << "  the truth with P" << o.converged_degree << " elements (" << name << ")" << std::endl;
      LinearizationRow row = linearization_row(m, c, name, "fem_neo_hookean");
      try
        {
          c.converged = truth_on_mesh(m, c, o.converged_mesh, row.fem_ms, log);
          for (unsigned step = 1; step <= c.n; ++step)
            series_row(study, m, c, name, step, *c.converged);
          row.errors  = compare(*c.truth, *c.converged, m.c0, c.first_begin, c.first_end);
          const RunErrors p1 = compare(*c.converged, *c.truth, m.c0, c.first_begin, c.first_end);
          log << "  the P1 truth against it: first contact: force " << p1.window_force
              << ", impulse " << p1.window_impulse << ", deformation " << p1.window_deformation
              << "; " << row.fem_ms << " ms/step" << std::endl;
        }
      catch (const std::exception &e)
        {
          log << "  the " << name << " truth failed: " << e.what() << std::endl;
          row.failed = e.what();
        }
      study.linearization.push_back(row);
      against_converged(m, c, "fem_neo_hookean", *c.truth, study);
      for (const std::string &mesh : c.converged ? o.converged_check_meshes : std::vector<std::string>{})
        {
          const std::string check = truth_name(o.converged_degree, mesh);
          log << "  the truth with P" << o.converged_degree << " elements (" << check
              << ") against " << name << std::endl;
          LinearizationRow r = linearization_row(m, c, check, name.c_str());
          try
            {
              const Samples s = truth_on_mesh(m, c, mesh, r.fem_ms, log);
              for (unsigned step = 1; step <= c.n; ++step)
                series_row(study, m, c, check, step, s);
              const RunErrors e = compare(*c.converged, s, m.c0, c.first_begin, c.first_end);
              r.errors          = e;
              log << "  first contact: force " << e.window_force << ", impulse "
                  << e.window_impulse << ", deformation " << e.window_deformation << "; "
                  << r.fem_ms << " ms/step" << std::endl;
            }
          catch (const std::exception &e)
            {
              log << "  the " << check << " truth failed: " << e.what() << std::endl;
              r.failed = e.what();
            }
          study.linearization.push_back(r);
        }
    }

    /// The linear FEM `lin` again with the floor `um` micrometres lower (the body starts that
    /// much higher above it), against itself by the same measures: what a change of the scene
    /// far below any the method makes does to each figure (1 um), or one whose first contact
    /// moves as much as the method's error does (larger shifts): how far the scene amplifies
    /// a first contact's error over the run.
    void
    run_sensitivity(const Material &m, CaseRun &c, const fem::Scene &lin, const double um,
                    FreeStudy &study, std::ostream &log)
    {
      const double shift = 1e-6 * um; // m
      fem::Scene   low   = lin;
      for (auto &v : low.planes[0].position.values)
        for (int d = 0; d < 3; ++d)
          v[d] -= shift * c.k.up(d);
      const std::string floor = "floor " + plain(um) + " um lower";
      LinearizationRow  row   = linearization_row(
        m, c, std::string(linear_fem_name(m.o)) + "_floor_" + plain(um) + "um", linear_fem_name(m.o));
      try
        {
          row.errors = compare(*c.small_strain, run_sampled(m, c, low, row.fem_ms), m.c0,
                               c.first_begin, c.first_end);
          log << "  the linear FEM with the " << floor << " against it: first contact: force "
              << row.errors.window_force << ", deformation " << row.errors.window_deformation
              << "; whole run: com "
              << row.errors.com << ", angle " << row.errors.angle << " deg, force "
              << row.errors.force << ", deformation " << row.errors.deformation << std::endl;
        }
      catch (const std::exception &e)
        {
          log << "  the linear FEM with the " << floor << " failed: " << e.what() << std::endl;
          row.failed = e.what();
        }
      study.linearization.push_back(row);
    }

    /// The linear FEM `lin` at half its step against itself, at tau's sample times (with
    /// --truth-check): how well the method's reference is determined by its step. A method's
    /// error against the linear FEM below this is not resolved by the step.
    void
    run_linear_half_step(const Material &m, const CaseRun &c, const fem::Scene &lin,
                         FreeStudy &study, std::ostream &log)
    {
      fem::Scene half = lin;
      half.time_step  = lin.time_step / 2;
      LinearizationRow row =
        linearization_row(m, c, std::string(linear_fem_name(m.o)) + "_half_step", linear_fem_name(m.o));
      try
        {
          row.errors = compare(*c.small_strain, run_sampled(m, c, half, row.fem_ms, 2), m.c0,
                               c.first_begin, c.first_end);
          log << "  the linear FEM at half its step against it: first contact: force "
              << row.errors.window_force << ", impulse " << row.errors.window_impulse
              << ", deformation " << row.errors.window_deformation << "; whole run: com "
              << row.errors.com << ", angle " << row.errors.angle << " deg, force "
              << row.errors.force << ", deformation " << row.errors.deformation << std::endl;
        }
      catch (const std::exception &e)
        {
          log << "  the linear FEM at half its step failed: " << e.what() << std::endl;
          row.failed = e.what();
        }
      study.linearization.push_back(row);
    }

    /// The linear FEM: the same solver, step, mesh and penalty contact with a linear law.
    /// Against the truth it is what linear elasticity itself misses (every linear method
    /// inherits it); the runtime against it is the method's own error. The body-frame law is
    /// linear elasticity in the body's best-fit frame, what the free routes linearize; the
    /// plain small-strain law is not objective (a finite turn strains it), so with it a body
    /// that starts spinning is left out.
    void
    run_linear_fem(const Material &m, CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      const auto &o = m.o;
      if (!o.small_strain || !(o.body_frame || c.k.spin.norm() == 0))
        return;
      fem::Scene lin       = c.s;
      lin.small_strain_law = true;
      lin.body_frame_law   = o.body_frame;
      log << "  the linear FEM (" << linear_fem_name(o) << ")" << std::endl;
      LinearizationRow row = linearization_row(m, c, linear_fem_name(o), "fem_neo_hookean");
      try
        {
          c.small_strain = run_sampled(m, c, lin, row.fem_ms);
          row.errors     = compare(*c.truth, *c.small_strain, m.c0, c.first_begin, c.first_end);
          // Its path in series.csv too, so that a method's departure from it can be timed.
          for (unsigned step = 1; step <= c.n; ++step)
            series_row(study, m, c, linear_fem_name(o), step, *c.small_strain);
          against_converged(m, c, linear_fem_name(o), *c.small_strain, study);
          log << "  the linear FEM against the truth: first contact: force "
              << row.errors.window_force << ", impulse " << row.errors.window_impulse
              << ", deformation " << row.errors.window_deformation << std::endl;
        }
      catch (const std::exception &e)
        {
          log << "  the linear FEM failed: " << e.what() << std::endl;
          row.failed = e.what();
        }
      study.linearization.push_back(row);
      if (o.truth_check && c.small_strain && !c.k.in_study()) // as the truth's own check
        run_linear_half_step(m, c, lin, study, log);
      if (o.sensitivity && c.small_strain)
        for (const double um : o.sensitivity_um)
          run_sensitivity(m, c, lin, um, study, log);
    }

    /// The FEM with the corotational law: against the truth, what the strain's nonlinearity
    /// adds; the linear FEM against it, what the rotation's does (each point's own rotation,
    /// which the linear laws take as one frame or none).
    void
    run_corotational_fem(const Material &m, const CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      if (!m.o.corotational)
        return;
      fem::Scene s       = c.s;
      s.corotational_law = true;
      log << "  the corotational FEM (fem_corotational)" << std::endl;
      LinearizationRow strain = linearization_row(m, c, "fem_corotational", "fem_neo_hookean");
      LinearizationRow turn   = linearization_row(m, c, linear_fem_name(m.o), "fem_corotational");
      try
        {
          const Samples corotational = run_sampled(m, c, s, strain.fem_ms);
          strain.errors = compare(*c.truth, corotational, m.c0, c.first_begin, c.first_end);
          against_converged(m, c, "fem_corotational", corotational, study);
          log << "  the corotational FEM against the truth: first contact: force "
              << strain.errors.window_force << ", impulse " << strain.errors.window_impulse
              << ", deformation " << strain.errors.window_deformation << "; "
              << strain.fem_ms << " ms/step" << std::endl;
          if (c.small_strain)
            turn.errors = compare(corotational, *c.small_strain, m.c0, c.first_begin, c.first_end);
        }
      catch (const std::exception &e)
        {
          log << "  the corotational FEM failed: " << e.what() << std::endl;
          strain.failed = turn.failed = e.what();
        }
      study.linearization.push_back(strain);
      if (c.small_strain)
        study.linearization.push_back(turn);
    }

    /// Frames of the rolling cat: six times evenly over the run.
    bool
    is_frame(const CaseRun &c, const unsigned step)
    {
      return c.k.name == "spin_roll" && step % std::max(1u, c.n / 6) == 0;
    }

    void
    write_frame(FreeStudy &study, const Material &m, const CaseRun &c, const char *method,
                const unsigned step, const std::vector<Eigen::Vector3d> &x)
    {
      for (size_t v = 0; v < x.size(); ++v)
        study.frames << c.k.name << ',' << material_name(m.E) << ',' << method << ','
                     << step * m.tau << ',' << v << ',' << x[v](0) << ',' << x[v](1) << ','
                     << x[v](2) << '\n';
    }

    /// A run's errors into its row: against the truth (whole run and first contact), the
    /// converged truth where it ran, and the linear FEM (the method's own error).
    void
    score(Row &row, const Samples &run, const Material &m, const CaseRun &c, FreeStudy &study)
    {
      const RunErrors err = compare(*c.truth, run, m.c0, c.first_begin, c.first_end);
      against_converged(m, c, row.method, run, study);
      // The truth's largest angle from its start, and how far it turned over the run.
      Eigen::Matrix3d previous = Eigen::Matrix3d::Identity();
      for (unsigned step = 1; step <= c.n; ++step)
        {
          const Eigen::Matrix3d &R = c.truth->fit[step].rotation;
          row.rotation_deg         = std::max(row.rotation_deg, angle_deg(R));
          row.turned_deg += angle_deg(R * previous.transpose());
          previous = R;
        }
      row.com_error = err.com, row.angle_error = err.angle, row.force_error = err.force;
      row.impulse_error = err.impulse, row.deformation_error = err.deformation;
      row.first_start       = (c.first_begin - 1) * m.tau;
      row.first_end         = (std::min(c.first_end, c.n + 1) - 1) * m.tau;
      row.first_force_error = err.window_force, row.first_impulse_error = err.window_impulse;
      row.first_deformation_error = err.window_deformation;
      if (c.small_strain)
        {
          LinearizationRow against = linearization_row(m, c, row.method, linear_fem_name(m.o));
          against.errors           = compare(*c.small_strain, run, m.c0, c.first_begin, c.first_end);
          row.method_force_error       = against.errors.force;
          row.method_impulse_error     = against.errors.impulse;
          row.method_deformation_error = against.errors.deformation;
          study.linearization.push_back(against);
        }
    }

    /// What the basis holds of the truth's deformation: its least-squares best over the
    /// comparison's vertices (every field, the truth's best-fit frame), relative L2 over the
    /// first contact and the run, as the deformation error is measured. A reduced run can do
    /// no better on these vertices; what it misses beyond this is its dynamics'.
    void
    log_basis_reach(const ReducedNonlinearModel &model, const std::vector<unsigned> &order,
                    const Material &m, const CaseRun &c, std::ostream &log)
    {
      const Eigen::Index V = static_cast<Eigen::Index>(m.rest.size()), r = model.size;
      Eigen::MatrixXd    A(3 * V, r);
      for (Eigen::Index v = 0; v < V; ++v)
        for (int d = 0; d < 3; ++d)
          A.row(3 * v + d) = Eigen::Map<const Eigen::RowVectorXd>(
            &model.basis[(3 * size_t(model.surface_vertex[order[v]]) + d) * r], r);
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
      RelativeL2                                        run, window;
      Eigen::VectorXd                                   d(3 * V);
      for (unsigned step = 1; step <= c.n; ++step)
        {
          for (Eigen::Index v = 0; v < V; ++v)
            d.segment<3>(3 * v) = c.truth->fit[step].deformation[v];
          const double miss2 = (A * qr.solve(d) - d).squaredNorm(), d2 = d.squaredNorm();
          run.add_squared(miss2, d2);
          if (step >= c.first_begin && step < c.first_end)
            window.add_squared(miss2, d2);
        }
      log << "  the basis holds the truth's deformation on " << V << " vertices (" << 3 * V << " rows, "
          << qr.rank() << " of " << r << " fields) to " << window.value() << " over the first contact, "
          << run.value() << " over the run" << std::endl;
    }

    /// A reduced nonlinear model of the free body (its six rigid modes in the basis; irdm
    /// precompute --reduced on the free scene): the truth's own law, penalty planes and
    /// integrator on the basis, started with the case's velocity, spin and gravity, the probe's
    /// force at its vertex, scored as the runtime's methods are; unstable where a step failed or
    /// its energy (kinetic, strain and gravity's; the penalty's left out) grew past 5 % of the
    /// energy brought in, as the routes' watch has it (Newton's relative stop can converge on a
    /// state that has run away).
    void
    run_reduced(const Material &m, const size_t which, const CaseRun &c, FreeStudy &study, std::ostream &log)
    {
      const ReducedNonlinearModel &model = m.reduced[which].model;
      const std::vector<unsigned> &order = m.reduced[which].order;
      const Case                  &k     = c.k;
      ReducedBodyOptions           options;
      options.floating_frame        = m.reduced[which].floating;
      options.keep_angular_momentum = m.reduced[which].keep_angular_momentum;
      ReducedNonlinearBody         body(model, options);
      const ReducedVertexForce     probe0{order[c.probe_vertex], c.probe_history.at(0)};
      if (!body.start(k.gravity ? arr(-9.81 * k.up) : fem::Vec3{0, 0, 0}, arr(k.velocity), arr(k.spin),
                      c.probed ? &probe0 : nullptr, c.probed))
        throw std::logic_error("validate-free: the reduced model refused the case's start");
      std::vector<ReducedPlane> planes(c.planes.size());
      for (size_t p = 0; p < c.planes.size(); ++p)
        {
          planes[p].normal  = c.planes[p].normal;
          planes[p].point   = c.planes[p].position.at(0);
          planes[p].penalty = c.fem_r.plane_penalty.at(c.planes[p].name);
        }
      Row row;
      row.c = k.name, row.method = m.reduced[which].method, row.E = m.E;
      row.impact_speed = k.impact_speed;
      row.fem_ms       = 1e3 * c.fem_seconds / c.n;
      const Eigen::Vector3d gravity = k.gravity ? Eigen::Vector3d(-9.81 * k.up) : Eigen::Vector3d::Zero();
      const auto energy = [&] { return body.energy() - model.mass * gravity.dot(body.center_of_mass()); };
      const double e0 = energy(), e_in = body.energy() + model.mass * gravity.norm() * k.height;
      double       work = 0, work_in = 0; // the probe's on the body
      Eigen::Vector3d probe_prev = m.rest[c.probe_vertex];
      Samples                      run(c.n);
      std::vector<double>          u(3 * model.surface_vertex.size());
      std::vector<Eigen::Vector3d> xi(m.rest.size());
      double                       seconds = 0, peak_f = 0, peak_i = 0;
      AngularMomentumBalance       window_balance, run_balance;
      for (unsigned step = 1; step <= c.n; ++step)
        {
          const ReducedVertexForce probe{order[c.probe_vertex], c.probe_history.at(step * m.tau)};
          const auto               t0 = Clock::now();
          body.step(planes.data(), static_cast<int>(planes.size()), c.probed ? &probe : nullptr, c.probed);
          seconds += std::chrono::duration<double>(Clock::now() - t0).count();
          if (body.floating())
            {
              run_balance.add(body, m.tau);
              if (step + 1 >= c.first_begin && step < c.first_end) // from the state before it
                window_balance.add(body, m.tau);
            }
          body.surface_displacement(u.data());
          for (size_t p = 0; p < planes.size(); ++p)
            run.force[step] += vec(body.plane_force(static_cast<int>(p)));
          run.impulse[step] = m.tau * run.force[step];
          run.com[step]     = body.center_of_mass();
          for (size_t v = 0; v < m.rest.size(); ++v)
            {
              const unsigned j = order[v];
              xi[v]            = m.rest[v] + Eigen::Vector3d(u[3 * j], u[3 * j + 1], u[3 * j + 2]);
              row.stable       = row.stable && xi[v].allFinite();
            }
          run.fit[step] = best_rigid_fit(m.rest, xi);
          if (c.probed)
            {
              const Eigen::Vector3d F0 = vec(c.probe_history.at((step - 1) * m.tau)),
                                    F1 = vec(c.probe_history.at(step * m.tau));
              const double          w  = 0.5 * (F0 + F1).dot(xi[c.probe_vertex] - probe_prev);
              work += w, work_in += std::abs(w);
              probe_prev = xi[c.probe_vertex];
            }
          row.energy_growth = std::max(row.energy_growth, (energy() - e0 - work) / std::max(e_in + work_in, 1e-300));
          series_row(study, m, c, row.method, step, run);
          peak_f = std::max(peak_f, c.truth->force[step].norm()), peak_i = std::max(peak_i, run.force[step].norm());
          if (is_frame(c, step))
            write_frame(study, m, c, row.method.c_str(), step, xi);
        }
      score(row, run, m, c, study);
      row.peak_ratio = peak_i / std::max(peak_f, 1e-300);
      row.irdm_us    = 1e6 * seconds / c.n;
      row.stable     = row.stable && body.failed_steps() == 0 && row.energy_growth < 0.05;
      log_basis_reach(model, order, m, c, log);
      if (body.floating())
        log << "  " << row.method << ": angular momentum over the first contact " << window_balance.text()
            << "; over the run " << run_balance.text() << std::endl;
      log << "  " << row.method << ": com " << row.com_error << ", angle " << row.angle_error
          << " deg, force " << row.force_error << ", impulse " << row.impulse_error
          << ", deformation " << row.deformation_error << "; first contact: force "
          << row.first_force_error << ", impulse " << row.first_impulse_error << ", deformation "
          << row.first_deformation_error << "; " << row.irdm_us << " us/step ("
          << body.cut_steps() << " steps cut, " << body.failed_steps() << " not converged; largest energy gain "
          << row.energy_growth << " of the energy brought in" << (row.stable ? "" : ": unstable") << ")" << std::endl;
      study.rows.push_back(row);
    }

    /// The runtime by one method, with the FEM's penalty as a per-vertex stiffness (each
    /// vertex weighed by its lumped area as the FEM's P1 contact weighs it; the virtual DOFs use
    /// their own wall), scored against the truth. `order[v]`: the runtime's index of the
    /// comparison's vertex v.
    template <class Runtime>
    void
    run_method(Runtime &irdm, const char *method, const std::vector<unsigned> &order,
               const Material &m, const CaseRun &c, const Eigen::Vector3d &gravity,
               FreeStudy &study, std::ostream &log)
    {
      const Case    &k     = c.k;
      const Samples &truth = *c.truth;
      const unsigned n     = c.n;
      const double   tau   = m.tau;
      irdm.rigid().set_velocity(k.velocity, k.spin);
      std::vector<PlaneTarget> targets(c.planes.size());
      for (size_t p = 0; p < c.planes.size(); ++p)
        {
          targets[p].normal  = c.planes[p].normal;
          targets[p].point   = c.planes[p].position.at(0);
          targets[p].penalty = c.fem_r.plane_penalty.at(c.planes[p].name);
        }
      EnergyWatch<Runtime> watch{irdm, gravity};
      watch.start(k.height);
      Eigen::Vector3d probe_prev = m.rest[c.probe_vertex]; // world = model frame at t = 0
      Row             row;
      row.c = k.name, row.method = method, row.E = m.E;
      row.impact_speed = k.impact_speed;
      row.fem_ms       = 1e3 * c.fem_seconds / n;
      std::vector<double>          x(3 * irdm.deformation().n_vertices());
      std::vector<Eigen::Vector3d> xi(m.rest.size());
      Samples                      run(n);
      double peak_f = 0, peak_i = 0, step_seconds = 0, centrifugal = 0, peak_contact = m.mass * 9.81;
      for (unsigned step = 1; step <= n; ++step)
        {
          const auto       t0 = Clock::now();
          const AppliedForce probe{c.probe_vertex, c.probe_history.at(step * tau)};
          const bool ok = c.probed ? irdm.step(targets.data(), static_cast<int>(targets.size()), &probe, 1)
                                   : irdm.step(targets.data(), static_cast<int>(targets.size()));
          step_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
          row.stable = row.stable && ok;
          irdm.surface_positions(x.data());
          const Eigen::Vector3d &F_f = truth.force[step];
          Eigen::Vector3d       &F_i = run.force[step];
          for (size_t p = 0; p < c.planes.size(); ++p)
            F_i += irdm.plane_force(static_cast<int>(p));
          run.impulse[step] = tau * F_i;
          peak_f = std::max(peak_f, F_f.norm()), peak_i = std::max(peak_i, F_i.norm());
          peak_contact = std::max(peak_contact, F_f.norm());
          run.com[step] = irdm.rigid().state().position;
          for (size_t v = 0; v < m.rest.size(); ++v)
            {
              const unsigned j = order[v];
              xi[v]            = Eigen::Vector3d(x[3 * j], x[3 * j + 1], x[3 * j + 2]);
              row.stable       = row.stable && xi[v].allFinite();
            }
          run.fit[step]  = best_rigid_fit(m.rest, xi);
          const double w = irdm.rigid().angular_velocity().norm();
          centrifugal    = std::max(centrifugal, m.mass * w * w * m.r_gyration);
          if (c.probed)
            {
              // The probe's work this step, trapezoidal as the loads (samples at the steps'
              // ends).
              const Eigen::Vector3d F0 = vec(c.probe_history.at((step - 1) * tau)),
                                    F1 = vec(c.probe_history.at(step * tau));
              const Eigen::Vector3d p  = xi[c.probe_vertex];
              watch.add_work(0.5 * (F0 + F1).dot(p - probe_prev));
              probe_prev = p;
            }
          row.energy_growth = std::max(row.energy_growth, watch.growth());
          series_row(study, m, c, method, step, run);
          if (is_frame(c, step))
            write_frame(study, m, c, method, step, xi);
        }
      score(row, run, m, c, study);
      row.peak_ratio  = peak_i / std::max(peak_f, 1e-300);
      row.irdm_us     = 1e6 * step_seconds / n;
      row.centrifugal = centrifugal / peak_contact;
      row.stable      = row.stable && row.energy_growth < 0.05;
      log << "  " << row.method << ": com " << row.com_error << ", angle " << row.angle_error
          << " deg, force " << row.force_error << ", impulse " << row.impulse_error
          << ", deformation " << row.deformation_error << ", IRDM " << row.irdm_us
          << " us/step, FEM " << row.fem_ms << " ms/step" << std::endl;
      study.rows.push_back(row);
    }

    /// One case of one material: the truth, its check, the linear FEM, every method.
    void
    run_case(Material &m, const Case &k, FreeStudy &study, std::ostream &log)
    {
      log << "validate-free: " << k.name << ", E = " << m.E << " Pa" << std::endl;
      CaseRun c = setup_case(m, k);
      if (!run_truth(m, c, study, log))
        return;
      run_converged_truth(m, c, study, log);
      if (m.o.truth_check && !k.in_study())
        run_truth_check(m, c, study, log);
      run_linear_fem(m, c, study, log);
      run_corotational_fem(m, c, study, log);
      for (unsigned step = 1; step <= c.n; ++step)
        if (is_frame(c, step))
          write_frame(study, m, c, "fem", step, c.fem_x[step]);
      FreeBodyOptions fo  = spin_options(m.o);
      fo.gravity          = k.gravity ? Eigen::Vector3d(-9.81 * k.up) : Eigen::Vector3d::Zero();
      std::vector<unsigned> identity(m.rest.size());
      for (unsigned v = 0; v < identity.size(); ++v)
        identity[v] = v;
      for (const NamedModel &nm : m.models)
        if (!nm.impact_study_only || k.in_study())
          {
            FreeBodyInteraction irdm(nm.model, fo);
            run_method(irdm, nm.method.c_str(), identity, m, c, fo.gravity, study, log);
          }
      // The virtual-DOF model holds responses to walls only (no probe); the impact study is
      // of the modal routes. It holds no mode shapes, so no spin coupling.
      if (m.vdof && !c.probed && !k.in_study())
        {
          FreeBodyOptions vo  = fo;
          vo.centrifugal      = false;
          vo.deformed_inertia = false;
          vo.euler = vo.spin_softening = vo.coriolis = vo.deformation_momentum = false;
          FreeBodyVirtualDofs irdm(*m.vdof, vo);
          run_method(irdm, vdof_method, m.vdof_order, m, c, vo.gravity, study, log);
        }
      for (size_t r = 0; r < m.reduced.size(); ++r)
        run_reduced(m, r, c, study, log);
    }

    /// The reduced models of this material (each file's Young's modulus against it), each
    /// comparison vertex found on the model's surface by its node tag at the same place.
    void
    prepare_reduced(Material &m, std::ostream &log)
    {
      for (const std::string &file : m.o.reduced_models)
        {
          ReducedModelOfBody r{"reduced_" + fs::path(file).stem().string(),
                               load_reduced_nonlinear_model(file, m.tau), {}};
          if (std::abs(young_modulus(r.model) - m.E) > 1e-6 * m.E)
            continue;
          const double nu = m.body.poisson_ratio, mu = m.E / (2 * (1 + nu)),
                       lambda = m.E * nu / ((1 + nu) * (1 - 2 * nu));
          const auto differs = [](const double a, const double b) {
            return std::abs(a - b) > 1e-6 * std::max(std::abs(a), std::abs(b));
          };
          if (differs(r.model.mu, mu) || differs(r.model.lambda, lambda) || differs(r.model.mass, m.mass) ||
              differs(r.model.rayleigh_alpha, m.body.rayleigh_alpha) ||
              differs(r.model.rayleigh_beta, m.body.rayleigh_beta))
            throw InputError("--reduced-model '" + file + "' is not a model of this body: its Lame "
                             "constants, mass or damping differ from the body's at " +
                             material_name(m.E));
          std::map<long long, unsigned> at;
          for (unsigned s = 0; s < r.model.node_tags.size(); ++s)
            at[r.model.node_tags[s]] = s;
          for (size_t v = 0; v < m.rest.size(); ++v)
            {
              const auto it = at.find(m.node_tags[v]);
              if (it == at.end() ||
                  (vec(r.model.coordinates[it->second]) - m.rest[v]).norm() > 1e-9 * (1 + m.rest[v].norm()))
                throw InputError("--reduced-model '" + file + "' is not a model of this body: its "
                                 "surface has no vertex of node tag " + std::to_string(m.node_tags[v]) +
                                 " where the body has one");
              r.order.push_back(it->second);
            }
          log << "validate-free: " << r.method << " (" << r.model.size << " fields, "
              << r.model.cubature_elements.size() << " elements) on the " << material_name(m.E)
              << " cases" << std::endl;
          {
            const ReducedNonlinearBody check(r.model); // a floating frame's refusals, before the long work
          }
          if (m.o.reduced_one_frame)
            {
              ReducedModelOfBody one = r;
              one.method += "_one_frame";
              one.floating = false;
              m.reduced.push_back(std::move(one));
            }
          if (m.o.reduced_projected_torque)
            {
              ReducedModelOfBody projected = r;
              projected.method += "_projected_torque";
              projected.keep_angular_momentum = false;
              m.reduced.push_back(std::move(projected));
            }
          m.reduced.push_back(std::move(r));
        }
    }

    /// The material's body, its models by both routes (and the virtual DOFs), and the
    /// comparison's vertices.
    void
    prepare_material(Material &m, const std::string &base_text, std::ostream &log)
    {
      const auto &o = m.o;
      m.body        = body_of(o, base_text, m.E);
      m.tau         = m.body.time_step;
      const bool study = runs_impact_study(o);
      for (const Route &route : routes)
        for (NamedModel &nm : free_model(
               m.body,
               (fs::path(o.model_dir) / ("free_cat_" + material_name(m.E) + route.file_suffix + ".h5")).string(),
               route.route, route.method, o.surface_modes, o.force_modes,
               study && route.route == fem::FreeBodyRoute::modal ? o.study_surface_modes : 0, log))
          m.models.push_back(std::move(nm));
      const ModalModel &frame = m.frame(); // the mesh, the vertices, the mass: shared
      m.rest.resize(frame.n_outputs / 3);
      for (size_t v = 0; v < m.rest.size(); ++v)
        m.rest[v] = vec(frame.output_coordinates[v]);
      m.node_tags          = frame.output_node_tags;
      m.output_input_index = frame.output_input_index;
      m.c0                 = vec(frame.center_of_mass);
      m.mass               = frame.mass;
      m.r_gyration = std::sqrt(0.5 * (frame.inertia[0][0] + frame.inertia[1][1] + frame.inertia[2][2]) / m.mass);
      if (o.vdof_subdivisions >= 0)
        prepare_virtual_dofs(m, log);
      prepare_reduced(m, log);
    }
  } // namespace

  Samples::Samples(const unsigned n)
    : force(n + 1, Eigen::Vector3d::Zero())
    , impulse(n + 1, Eigen::Vector3d::Zero())
    , com(n + 1, Eigen::Vector3d::Zero())
    , fit(n + 1)
  {}

  double
  young_modulus(const ReducedNonlinearModel &model)
  {
    return model.mu * (3 * model.lambda + 2 * model.mu) / (model.lambda + model.mu);
  }

  FreeStudy::FreeStudy()
  {
    series << "case,material,method,time_s,fem_force_N,irdm_force_N,fem_com_z_m,irdm_com_z_m,"
              "fem_angle_deg,irdm_angle_deg,fem_deformation_rms_m,deformation_difference_rms_m\n";
    frames << "case,material,method,time_s,vertex,x_m,y_m,z_m\n";
    stability_csv << "material,method,time_s,energy_gain,elastic_energy_over_input,turned_deg,"
                     "active_vertices,deepest_below_floor_m\n";
  }

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


  std::string
  converged_truth_name(const FreeBodyValidationOptions &o)
  {
    return truth_name(o.converged_degree, o.converged_mesh);
  }

  void
  run_material(const FreeBodyValidationOptions &o, const std::string &base_text, const double E,
               const unsigned M, FreeStudy &study, std::ostream &log)
  {
    Material m{o, E, M};
    prepare_material(m, base_text, log);
    study.triangles = m.frame().triangles;
    for (const Case &k : chosen_cases(o))
      run_case(m, k, study, log);
    run_stability(m, study, log);
  }
  FreeBodyOptions
  spin_options(const FreeBodyValidationOptions &o)
  {
    FreeBodyOptions fo;
    fo.centrifugal      = o.centrifugal;
    fo.deformed_inertia = o.deformed_inertia;
    fo.euler = fo.spin_softening = fo.coriolis = o.frame_forces;
    fo.frame_modes                              = o.frame_modes;
    fo.deformation_momentum                     = o.deformation_momentum;
    return fo;
  }
} // namespace irdm::validation::free_body
