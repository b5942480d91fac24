// The plane study's runner (plane_runs.h): the models, each case through the truth and every
// method, the device-held plate, and the orientation mapping's diagnosis.
#include "plane_runs.h"
#include "metrics.h"
#include "surface_transfer.h"

#include <irdm/point_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/mesh.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/virtual_dof.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

namespace fs = std::filesystem;

namespace irdm::validation::planes
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    double
    since(const Clock::time_point t0)
    {
      return std::chrono::duration<double>(Clock::now() - t0).count();
    }

    void
    create_parent(const std::string &file)
    {
      if (!fs::path(file).parent_path().empty())
        fs::create_directories(fs::path(file).parent_path());
    }

    /// The virtual-DOF model, reused when its spec matches.
    void
    prepare_virtual_dofs(const fem::Scene &body, const PlaneValidationOptions &o,
                         PlaneModels &m, std::ostream &log)
    {
      bool reuse = false;
      if (fs::exists(o.model_file))
        try
          {
            const h5::Reader r(o.model_file);
            const auto       shape = r.shape("/virtual_dofs/surface_response");
            const unsigned   K     = 10u * (1u << (2 * o.subdivisions)) + 2;
            reuse = r.string_attribute("/", "scene") == body.json_text && shape.size() == 3 &&
                    shape[0] == K && shape[1] == o.length;
          }
        catch (const InputError &)
          {}
      if (!reuse && fs::exists(o.model_file))
        throw InputError("--model '" + o.model_file + "' exists but is not a virtual-DOF model of "
                         "this scene with " + std::to_string(o.subdivisions) + " subdivisions and "
                         "T = " + std::to_string(o.length) + " (a point model, another scene or "
                         "another spec); it is never overwritten: remove it or choose another path");
      if (!reuse)
        {
          create_parent(o.model_file);
          fem::VirtualDofOptions vo;
          vo.output         = o.model_file;
          vo.subdivisions   = o.subdivisions;
          vo.length         = o.length;
          vo.double_storage = false; // the runtime reads the responses as float
          vo.log            = [&](const std::string &s) { log << "  " << s << "\n"; };
          log << "precomputing the virtual-DOF model " << o.model_file << "\n";
          m.seconds_per_orientation = fem::precompute_virtual_dofs(body, vo).seconds_per_orientation_mean;
        }
      m.vdof = load_virtual_dof_model(o.model_file, body.time_step);
      if (reuse)
        {
          const h5::Reader r(o.model_file);
          const auto       secs = r.read_double("/virtual_dofs/seconds", {m.vdof.n_orientations});
          for (const double s : secs)
            m.seconds_per_orientation += s / secs.size();
        }
      log << "virtual-DOF model: " << m.vdof.n_orientations << " orientations x "
          << m.vdof.length << " samples, " << m.vdof.n_surface << " surface vertices\n";
    }

    /// The vertex-contact model: every free surface vertex an input and an output, the linear
    /// FEM's impulse responses (reused when made from this scene with this length).
    void
    prepare_vertex_model(const fem::Scene &body, const PlaneValidationOptions &o,
                         PlaneModels &m, std::ostream &log)
    {
      fem::Scene linear_body = body;
      linear_body.kinematics = fem::Kinematics::linear;
      linear_body.model.inputs.reset();
      linear_body.model.outputs.reset();
      if (fs::exists(o.vertex_model_file))
        try
          {
            const h5::Reader r(o.vertex_model_file);
            m.vertex_reused = r.string_attribute("/", "scene") == body.json_text &&
                              r.string_attribute("/", "format") == "irdm-impulse-response" &&
                              r.shape("/inputs/node_tags") == r.shape("/outputs/node_tags");
          }
        catch (const InputError &)
          {}
      if (!m.vertex_reused && fs::exists(o.vertex_model_file))
        throw InputError("--vertex-model '" + o.vertex_model_file + "' exists but is not the "
                         "every-surface-vertex model of this scene; it is never overwritten: "
                         "remove it or choose another path");
      if (!m.vertex_reused)
        {
          create_parent(o.vertex_model_file);
          fem::PrecomputeOptions po;
          po.output         = o.vertex_model_file;
          po.length         = o.length;
          po.double_storage = false;
          po.log            = [&](const std::string &x) { log << "  " << x << "\n"; };
          log << "precomputing the vertex-contact model " << o.vertex_model_file << "\n";
          const auto t0 = Clock::now();
          fem::precompute_impulse_responses(linear_body, po);
          m.vertex_precompute_seconds = since(t0);
        }
      m.vertex = load_model(o.vertex_model_file, body.time_step);
      if (m.vertex.length < o.length)
        throw InputError("--vertex-model '" + o.vertex_model_file + "' has T = " +
                         std::to_string(m.vertex.length) + " < --length " +
                         std::to_string(o.length));
      m.modal = make_modal_model(m.vertex, {o.surface_modes});
      log << "vertex-contact model: " << m.vertex.n_inputs / 3 << " surface vertices, "
          << m.modal.n_modes << " modes (" << m.modal.surface_modes
          << " in the surface update), direct H " << m.vertex.bytes() / 1e9 << " GB, modal "
          << m.modal.bytes() / 1e9 << " GB\n";
    }

    /// The converged truth's series, on the truth's own steps and surface vertices.
    struct ConvergedTruth
    {
      std::vector<double>              F;       // N, per step 0..N, along -d
      std::vector<std::vector<double>> surface; // m, per step: 3 x the truth's surface vertices
    };

    /// One case's truth: the nonlinear FEM, each wall the plane through w(t) d with normal
    /// -d, sampled at every step.
    struct Truth
    {
      const Case    &c;
      const PlaneModels &models;
      double         tau;
      fem::Scene     scene;
      unsigned       N = 0;
      std::shared_ptr<const fem::RunResult> run; // shared by the perturbed cases
      double         u_max = 0; // m, the FEM's largest surface displacement component
      // The converged truth (PlaneValidationOptions::converged_degree and converged_mesh), its
      // force along -d per step and its surface displacement at this truth's surface vertices;
      // null where it did not run.
      std::shared_ptr<const ConvergedTruth> converged;

      double
      wall_at(const size_t a, const double t) const
      {
        return wall_position(c, models.vdof, a, t);
      }
    };

    /// The walls' total force along -d of a run of scene s, per step 0..N.
    std::vector<double>
    wall_force(const Truth &truth, const fem::RunResult &r, const fem::Scene &s)
    {
      std::vector<double> F(truth.N + 1, 0.0);
      for (unsigned k = 0; k <= truth.N; ++k)
        for (size_t a = 0; a < truth.c.d.size(); ++a)
          F[k] -= dot(r.plane_force.at(s.planes[a].name)[k], direction(truth.c, a, k * truth.tau));
      return F;
    }

    void
    run_truth(Truth &truth, const fem::Scene &body, Row &row, std::ostream &log)
    {
      const Case  &c   = truth.c;
      const double tau = truth.tau;
      fem::Scene  &s   = truth.scene;
      s                = body;
      s.name           = c.name;
      s.duration       = c.duration;
      truth.N          = s.n_steps();
      const unsigned N = truth.N;
      s.planes.clear();
      for (size_t a = 0; a < c.d.size(); ++a)
        {
          fem::RigidPlane wall;
          wall.name   = "wall" + std::to_string(a);
          wall.normal = {-c.d[a][0], -c.d[a][1], -c.d[a][2]};
          for (unsigned k = 0; k <= N; ++k)
            {
              const double w = truth.wall_at(a, k * tau);
              const Vec3   d = direction(c, a, k * tau);
              wall.position.times.push_back(k * tau);
              wall.position.values.push_back({w * d[0], w * d[1], w * d[2]});
              if (!c.turn_times.empty())
                {
                  wall.normal_path.times.push_back(k * tau);
                  wall.normal_path.values.push_back({-d[0], -d[1], -d[2]});
                }
            }
          s.planes.push_back(wall);
        }
      log << c.name << ": FEM ..." << std::flush;
      const auto t0 = Clock::now();
      truth.run     = std::make_shared<const fem::RunResult>(fem::NonlinearElasticity(s).run());
      const auto &r = *truth.run;
      row.fem_ms_per_step = 1e3 * r.stepping_seconds / N;
      row.newton          = r.newton_iterations;
      for (const double e : r.largest_strain)
        row.largest_strain = std::max(row.largest_strain, e);
      row.F_fem = wall_force(truth, r, s);
      for (unsigned k = 0; k <= N; ++k)
        {
          for (size_t a = 0; a < c.d.size(); ++a)
            row.fem_max_penetration =
              std::max(row.fem_max_penetration, r.plane_penetration.at(s.planes[a].name)[k]);
          row.fem_peak_force = std::max(row.fem_peak_force, row.F_fem[k]);
        }
      for (unsigned k = 1; k <= N; ++k)
        for (const double x : r.surface_displacement[k])
          truth.u_max = std::max(truth.u_max, std::abs(x));
      log << " " << since(t0) << " s; IRDM";
    }

    /// The vertices of a mesh's free surface: of its boundary triangles, those on no fixed
    /// surface (as a virtual-DOF model's free surface vertices).
    std::vector<Vec3>
    free_surface_vertices(const fem::TetMesh &mesh, const std::vector<std::string> &fixed)
    {
      std::vector<char> on_fixed(mesh.vertices.size(), 0), on_boundary(mesh.vertices.size(), 0);
      std::vector<int>  fixed_tags;
      for (const std::string &name : fixed)
        fixed_tags.push_back(mesh.surface_tag(name));
      for (size_t t = 0; t < mesh.triangles.size(); ++t)
        {
          const bool f = std::find(fixed_tags.begin(), fixed_tags.end(), mesh.triangle_tags[t]) !=
                         fixed_tags.end();
          for (const unsigned v : mesh.triangles[t])
            (f ? on_fixed : on_boundary)[v] = 1;
        }
      std::vector<Vec3> x;
      for (size_t v = 0; v < mesh.vertices.size(); ++v)
        if (on_boundary[v] && !on_fixed[v])
          x.push_back(mesh.vertices[v]);
      return x;
    }

    /// The support max_i d . x_i of a vertex set (m): where a press of depth 0 puts its wall.
    double
    support(const std::vector<Vec3> &x, const Vec3 &d)
    {
      double h = -INFINITY;
      for (const Vec3 &p : x)
        h = std::max(h, dot(d, p));
      return h;
    }

    /// The walls of scene s moved onto another mesh's body: each wall's depth measured from that
    /// mesh's own outermost free point along the wall's direction, as the case's depth is from
    /// the truth's (a finer mesh's facets reach out differently, and at a shallow press that
    /// difference is the press).
    void
    walls_onto_mesh(fem::Scene &s, const Truth &truth, const std::string &mesh_file)
    {
      const auto from = free_surface_vertices(fem::read_gmsh(truth.scene.mesh_file), s.fixed_surfaces);
      const auto to   = free_surface_vertices(fem::read_gmsh(mesh_file), s.fixed_surfaces);
      for (size_t a = 0; a < s.planes.size(); ++a)
        for (unsigned k = 0; k <= truth.N; ++k)
          {
            const Vec3   d     = direction(truth.c, a, k * truth.tau);
            const double shift = support(to, d) - support(from, d);
            for (int i = 0; i < 3; ++i)
              s.planes[a].position.values[k][i] += shift * d[i];
          }
      s.mesh_file = mesh_file;
    }

    /// A run's surface displacement at another surface's vertices (surface_transfer.h). `gap`
    /// returns the largest distance from a vertex to the run's surface (m): the two faceted
    /// bodies'.
    std::vector<std::vector<double>>
    on_vertices(const fem::SurfaceMesh &to, const fem::RunResult &r, double &gap)
    {
      const SurfaceTransfer t = surface_transfer(r.surface.coordinates, r.surface.triangles, to.coordinates);
      gap                     = t.gap;
      std::vector<std::vector<double>> u;
      for (const auto &step : r.surface_displacement)
        u.push_back(transferred(t, step));
      return u;
    }

    /// The converged truth: the truth's walls on elements of degree o.converged_degree, on the
    /// same mesh or on o.converged_mesh (a finer one), and the P1 truth against it.
    void
    run_converged_truth(Truth &truth, const PlaneValidationOptions &o, Row &row, std::ostream &log)
    {
      fem::Scene s = truth.scene;
      s.fe_degree  = o.converged_degree;
      row.converged_truth = converged_truth_name(o);
      log << " " << row.converged_truth << " ..." << std::flush;
      try
        {
          if (!o.converged_mesh.empty())
            walls_onto_mesh(s, truth, o.converged_mesh);
          const fem::NonlinearElasticity fem(s);
          const fem::RunResult           r = fem.run();
          auto                           converged = std::make_shared<ConvergedTruth>();
          converged->F = wall_force(truth, r, s);
          if (o.converged_mesh.empty())
            converged->surface = r.surface_displacement;
          else
            converged->surface = on_vertices(truth.run->surface, r, row.converged_surface_gap);
          truth.converged      = converged;
          row.converged_ms     = 1e3 * r.stepping_seconds / truth.N;
          row.converged_degree = o.converged_degree;
          row.converged_dofs   = fem.n_dofs();
          RelativeL2   force, displacement;
          ImpulseError impulse;
          for (unsigned k = 1; k <= truth.N; ++k)
            {
              force.add(row.F_fem[k], converged->F[k]);
              impulse.add(row.F_fem[k], converged->F[k]);
              displacement.add(truth.run->surface_displacement[k], converged->surface[k]);
              row.converged_peak_force = std::max(row.converged_peak_force, converged->F[k]);
            }
          row.truth_force_error        = force.value();
          row.truth_impulse_error      = impulse.value();
          row.truth_displacement_error = displacement.value();
          log << " " << row.converged_ms << " ms/step, peak " << row.converged_peak_force
              << " N (P1 " << row.fem_peak_force << " N)";
          if (!o.converged_mesh.empty())
            log << ", surfaces at most " << 1e3 * row.converged_surface_gap << " mm apart";
          log << ";" << std::flush;
        }
      catch (const std::exception &e)
        {
          truth.converged.reset();
          log << " the " << row.converged_truth << " FEM failed: " << e.what() << ";" << std::flush;
        }
    }

    /// Scores a method stepped as every method is: IRDM step n (n = 0, 1, ...) is FEM step
    /// n + 1, with the walls where the FEM has them at its end. step(t, F) advances to t and
    /// gives the total wall force along -d; surface() the surface in the FEM's order.
    template <class Step, class Surface>
    void
    score(MethodResult &m, const Truth &truth, const Row &row, Step &&step, Surface &&surface)
    {
      RelativeL2     force, displacement, converged_force, converged_displacement;
      ImpulseError   impulse, converged_impulse;
      double         t_force = 0, t_surface = 0;
      const unsigned N = truth.N;
      m.ran            = true;
      for (unsigned k = 1; k <= N; ++k)
        {
          const auto t1 = Clock::now();
          double     F  = 0;
          const bool ok = step(k * truth.tau, F);
          t_force += since(t1);
          m.stable = m.stable && ok && std::isfinite(F);
          m.F.push_back(F);
          const auto  t2 = Clock::now();
          const auto &u  = surface();
          t_surface += since(t2);
          force.add(F, row.F_fem[k]);
          impulse.add(F, row.F_fem[k]);
          displacement.add(u, truth.run->surface_displacement[k]);
          if (truth.converged)
            {
              converged_force.add(F, truth.converged->F[k]);
              converged_impulse.add(F, truth.converged->F[k]);
              converged_displacement.add(u, truth.converged->surface[k]);
            }
          for (const double x : u)
            m.stable = m.stable && std::isfinite(x) && std::abs(x) <= 10 * truth.u_max;
        }
      m.force_error        = force.value();
      m.impulse_error      = impulse.value();
      m.displacement_error = displacement.value();
      if (truth.converged)
        {
          m.converged_force_error        = converged_force.value();
          m.converged_impulse_error      = converged_impulse.value();
          m.converged_displacement_error = converged_displacement.value();
        }
      m.force_us           = 1e6 * t_force / N;
      m.surface_us         = 1e6 * t_surface / N;
    }

    /// Wall a at time t as a plane: its normal toward the body (-d) and a point of it (w d).
    struct WallPlane
    {
      Vec3 normal, point;
    };
    WallPlane
    wall_plane(const Truth &truth, const size_t a, const double t)
    {
      const double w = truth.wall_at(a, t);
      const Vec3   d = direction(truth.c, a, t);
      return {{-d[0], -d[1], -d[2]}, {w * d[0], w * d[1], w * d[2]}};
    }

    /// Virtual DOFs with the given orientation mapping and wall stiffness k (0: rigid).
    void
    run_virtual_dofs(MethodResult &m, const Truth &truth, const Row &row,
                     const OrientationMapping mapping, const double k)
    {
      const Case                                      &c       = truth.c;
      const size_t                                     n_walls = c.d.size();
      PlaneInteraction                                 run(truth.models.vdof, mapping);
      std::array<VirtualDofWall, PlaneInteraction::max_walls> walls;
      std::array<double, PlaneInteraction::max_walls>         force{};
      m.stiffness = k;
      score(
        m, truth, row,
        [&](const double t, double &F) {
          for (size_t a = 0; a < n_walls; ++a)
            walls[a] = {direction(c, a, t), truth.wall_at(a, t), k};
          const bool ok = run.step(walls.data(), static_cast<int>(n_walls), force.data());
          F             = 0;
          for (size_t a = 0; a < n_walls; ++a)
            {
              F += force[a];
              if (k > 0)
                m.max_penetration = std::max(m.max_penetration, force[a] / k);
            }
          return ok;
        },
        [&]() -> const std::vector<double> & { return run.update_surface(); });
    }

    /// Many-vertex contact on a runtime (ModalInteraction or PointInteraction), walls of
    /// stiffness k per vertex. Its surface holds the free surface vertices, put back in the
    /// FEM's order for the comparison (fixed: zero).
    template <class Runtime>
    void
    run_vertex_contact(Runtime &runtime, MethodResult &m, const Truth &truth, const Row &row,
                       const double k, const std::vector<unsigned> &fem_order)
    {
      const Case  &c       = truth.c;
      const size_t n_walls = c.d.size();
      const auto  &vertex  = truth.models.vertex;
      std::vector<double> u_out(vertex.n_outputs), u_fem_order(3 * truth.run->surface.node_tags.size());
      std::array<PlaneTarget, contact::max_planes> targets;
      m.contact_vertices_max = m.candidates_max = m.rounds_max = 0;
      m.stiffness = k;
      score(
        m, truth, row,
        [&](const double t, double &F) {
          for (size_t a = 0; a < n_walls; ++a)
            {
              const WallPlane wall = wall_plane(truth, a, t);
              targets[a].normal    = wall.normal;
              targets[a].point     = wall.point;
              targets[a].stiffness = k;
            }
          const bool ok = runtime.step(targets.data(), static_cast<int>(n_walls));
          F             = 0;
          int active    = 0;
          for (size_t a = 0; a < n_walls; ++a)
            {
              const auto &r = runtime.vertex_contact().plane(static_cast<int>(a));
              F += dot(r.force, targets[a].normal);
              active += r.active;
              m.max_penetration = std::max(m.max_penetration, r.penetration);
            }
          m.contact_vertices_max = std::max(m.contact_vertices_max, active);
          m.candidates_max = std::max(m.candidates_max, runtime.vertex_contact().candidates());
          m.rounds_max     = std::max(m.rounds_max, runtime.vertex_contact().rounds());
          return ok;
        },
        [&]() -> const std::vector<double> & {
          runtime.surface_displacement(u_out.data());
          for (unsigned j = 0; j < vertex.n_outputs; ++j)
            u_fem_order[3 * fem_order[j / 3] + j % 3] = u_out[j];
          return u_fem_order;
        });
    }

    void
    run_vertex_modal(MethodResult &m, const Truth &truth, const Row &row, const double k,
                     const std::vector<unsigned> &fem_order)
    {
      ModalInteraction run(truth.models.modal, truth.models.contact);
      run_vertex_contact(run, m, truth, row, k, fem_order);
    }

    /// A reduced nonlinear model with the truth's penalty walls (the same rigid planes, the
    /// same node-based penalty): its surface put in the truth's order by node tag.
    void
    run_reduced(MethodResult &m, std::array<unsigned long, 2> &cut_failed, const Truth &truth,
                const Row &row, const ReducedNonlinearModel &model, const double penalty,
                const double newton_tolerance)
    {
      const Case         &c       = truth.c;
      const size_t        n_walls = c.d.size();
      const auto         &surface = truth.run->surface;
      std::map<long long, unsigned> at;
      for (unsigned i = 0; i < surface.node_tags.size(); ++i)
        at[surface.node_tags[i]] = i;
      std::vector<unsigned> order;
      for (const long long tag : model.node_tags)
        {
          const auto it = at.find(tag);
          if (it == at.end())
            throw InputError("reduced model '" + model.path + "': its surface is not the scene's "
                             "(a vertex the truth's surface does not have)");
          order.push_back(it->second);
        }
      ReducedBodyOptions options;
      options.tolerance = newton_tolerance;
      ReducedNonlinearBody body(model, options);
      std::array<ReducedPlane, ReducedNonlinearBody::max_planes> walls;
      std::vector<double> u(3 * model.node_tags.size()), u_truth_order(3 * surface.node_tags.size());
      score(
        m, truth, row,
        [&](const double t, double &F) {
          for (size_t a = 0; a < n_walls; ++a)
            {
              const WallPlane wall = wall_plane(truth, a, t);
              walls[a].normal      = wall.normal;
              walls[a].point       = wall.point;
              walls[a].penalty     = penalty;
            }
          body.step(walls.data(), static_cast<int>(n_walls));
          F = 0;
          for (size_t a = 0; a < n_walls; ++a)
            F += dot(body.plane_force(static_cast<int>(a)), walls[a].normal);
          return true; // a step not converged is still taken (counted)
        },
        [&]() -> const std::vector<double> & {
          body.surface_displacement(u.data());
          for (size_t j = 0; j < order.size(); ++j)
            for (int d = 0; d < 3; ++d)
              u_truth_order[3 * order[j] + d] = u[3 * j + d];
          return u_truth_order;
        });
      cut_failed = {body.cut_steps(), body.failed_steps()};
    }

    /// A recorded FEM run of the case's walls (scene ls) scored as a method: its wall force
    /// along -d at each step (d as the wall turns) and its surface.
    void
    replay(MethodResult &m, const Truth &truth, const Row &row, const fem::RunResult &run,
           const fem::Scene &ls)
    {
      unsigned k = 0;
      score(
        m, truth, row,
        [&](double, double &F) {
          ++k;
          F = 0;
          for (size_t a = 0; a < truth.c.d.size(); ++a)
            F -= dot(run.plane_force.at(ls.planes[a].name)[k], direction(truth.c, a, k * truth.tau));
          return true;
        },
        [&]() -> const std::vector<double> & { return run.surface_displacement[k]; });
    }

    /// The corotational law with the truth's contact against the truth, and the small-strain
    /// law's run `law` (scene ls) against it.
    void
    run_corotational(Row &row, const Truth &truth, const fem::RunResult &law,
                     const fem::Scene &ls, std::ostream &log)
    {
      fem::Scene cs       = truth.scene;
      cs.corotational_law = true;
      try
        {
          const auto run = std::make_shared<const fem::RunResult>(fem::NonlinearElasticity(cs).run());
          row.corotational_ms = 1e3 * run->stepping_seconds / truth.N; // as the truth's
          replay(row.corotational, truth, row, *run, cs);
          Row against = row; // the corotational run's force as the reference's
          against.F_fem.assign(1, 0.0);
          against.F_fem.insert(against.F_fem.end(), row.corotational.F.begin(), row.corotational.F.end());
          const Truth reference{truth.c, truth.models, truth.tau, cs, truth.N, run, truth.u_max, nullptr};
          replay(row.rotation, reference, against, law, ls);
          log << " corotational " << row.corotational_ms << " ms/step" << std::flush;
        }
      catch (const std::exception &e)
        {
          log << " the corotational FEM failed: " << e.what() << std::flush;
        }
    }

    /// The linear FEM with the same vertex contact (fixed walls only: linear planes keep their
    /// normal) and, where vertex contact misses the goal (5 % impulse and displacement, 10 %
    /// force) or the corotational split is asked, the small-strain law with the truth's own
    /// contact, which says why; elsewhere it would cost a nonlinear run per case for nothing.
    void
    run_linear_references(Row &row, const Truth &truth, const bool corotational, std::ostream &log)
    {
      if (truth.c.turn_times.empty())
        {
          fem::Scene ls = truth.scene;
          ls.kinematics = fem::Kinematics::linear;
          for (auto &p : ls.planes)
            p.penalty = 0, p.vertex_stiffness = row.vertex_stiffness;
          const auto t1  = Clock::now();
          const auto lin = fem::ElasticDynamics(ls).run();
          row.linear_fem_seconds = since(t1);
          replay(row.linear_fem, truth, row, lin, ls);
          log << " linear FEM " << row.linear_fem_seconds << " s" << std::flush;
        }
      bool misses = false;
      for (const int m : {2, 3})
        if (row.method[m].ran)
          misses = misses || row.method[m].impulse_error > 0.05 ||
                   row.method[m].displacement_error > 0.05 || row.method[m].force_error > 0.10;
      if (!misses && !corotational)
        return;
      fem::Scene ls       = truth.scene;
      ls.small_strain_law = true;
      const fem::RunResult law = fem::NonlinearElasticity(ls).run();
      row.linear_law_ms        = 1e3 * law.stepping_seconds / truth.N;
      replay(row.linear_law, truth, row, law, ls);
      log << " linear law" << std::flush;
      if (corotational)
        run_corotational(row, truth, law, ls, log);
    }

    /// Compliant walls: vdof_nearest and vertex_contact_modal at each stiffness of the sweep,
    /// and vertex contact at the FEM penalty's per-vertex equivalent.
    std::vector<SweepRow>
    run_stiffness_sweep(const Truth &truth, const Row &row, const PlaneValidationOptions &o,
                        const double penalty, const std::vector<unsigned> &fem_order)
    {
      std::vector<SweepRow> sweep;
      auto                  ks = o.stiffness_sweep;
      ks.push_back(penalty * truth.models.mean_vertex_area);
      for (const double k : ks)
        {
          SweepRow sr{truth.c.name, "vertex_contact_modal", k, k == ks.back(), {}};
          run_vertex_modal(sr.result, truth, row, k, fem_order);
          sweep.push_back(sr);
          if (k == ks.back())
            continue; // the FEM equivalent is per vertex only
          sr = {truth.c.name, "vdof_nearest", k, false, {}};
          run_virtual_dofs(sr.result, truth, row, OrientationMapping::nearest, k);
          sweep.push_back(sr);
        }
      return sweep;
    }

    /// Every method again under small perturbations of the scene. A figure that moves under
    /// so small a change is not decided by the scene: a unilateral contact that chatters
    /// follows the order of its touches, and a wall that creeps in can leave the body in
    /// steady contact or in a bouncing cycle, which of the two the last bits decide (another
    /// CPU's BLAS kernels in the precompute switch it). Perturbation i scales, by 1 + eps,
    /// the walls' penetration (i % 3 = 0), the time of the walls' motion, that is their speed
    /// (1), or the vertex contact's wall stiffness (2); eps = +-1e-6 or +-1e-3 in turn, so that
    /// both the round-off's scale and a change that moves a figure decided by the scene by a
    /// thousandth are tried. The truth is not run again: it moves by as little. The time is
    /// scaled by 1e-6 only: by 1e-3 it would move the release by a third of a millisecond,
    /// which a force error measured sample by sample against the truth's does feel.
    void
    run_perturbed(Row &row, const Truth &truth, const PlaneValidationOptions &o,
                  const std::vector<unsigned> &fem_order)
    {
      for (auto &m : row.method)
        if (m.ran)
          m.force_range.add(m.force_error), m.impulse_range.add(m.impulse_error),
            m.displacement_range.add(m.displacement_error);
      for (unsigned i = 0; i < o.perturbations; ++i)
        {
          const unsigned kind = i % 3, size = i / 3;
          const double   eps  = (size % 2 ? -1.0 : 1.0) * (size / 2 % 2 && kind != 1 ? 1e-3 : 1e-6);
          Case           c    = truth.c;
          double         k    = row.vertex_stiffness;
          if (kind == 0)
            for (double &p : c.penetration)
              p *= 1 + eps;
          else if (kind == 1)
            for (double &t : c.times)
              t *= 1 + eps;
          else
            k *= 1 + eps;
          const Truth  t{c, truth.models, truth.tau, truth.scene, truth.N, truth.run, truth.u_max, nullptr};
          std::array<MethodResult, method_names.size()> m;
          run_virtual_dofs(m[0], t, row, OrientationMapping::nearest, 0);
          run_virtual_dofs(m[1], t, row, OrientationMapping::interpolated, 0);
          run_vertex_modal(m[2], t, row, k, fem_order);
          if (o.direct)
            {
              PointInteraction run(t.models.vertex, 0, t.models.contact);
              run_vertex_contact(run, m[3], t, row, k, fem_order);
            }
          for (size_t j = 0; j < m.size(); ++j)
            if (m[j].ran)
              {
                row.method[j].force_range.add(m[j].force_error);
                row.method[j].impulse_range.add(m[j].impulse_error);
                row.method[j].displacement_range.add(m[j].displacement_error);
              }
        }
    }

    /// The virtual-DOF surface driven by the FEM's own wall force (one wall, interpolated).
    double
    open_loop_displacement_error(const Truth &truth, const Row &row)
    {
      PlaneInteraction run(truth.models.vdof, OrientationMapping::interpolated);
      RelativeL2       displacement;
      for (unsigned k = 1; k <= truth.N; ++k)
        {
          run.apply(direction(truth.c, 0, k * truth.tau), row.F_fem[k]);
          displacement.add(run.update_surface(), truth.run->surface_displacement[k]);
        }
      return displacement.value();
    }
  } // namespace

  fem::Scene
  grounded_body(const std::string &scene)
  {
    fem::Scene body = fem::read_scene(scene);
    body.probes.clear();
    body.prescribed.clear();
    body.outputs         = fem::Scene::Outputs();
    body.outputs.hdf5    = body.outputs.csv = false;
    body.outputs.surface = true;
    body.gravity_enabled = false;
    body.kinematics      = fem::Kinematics::nonlinear;
    return body;
  }

  std::string
  converged_truth_name(const PlaneValidationOptions &o)
  {
    return truth_name(o.converged_degree, o.converged_mesh);
  }

  PlaneModels
  prepare_models(const fem::Scene &body, const PlaneValidationOptions &o, std::ostream &log)
  {
    if (!o.converged_mesh.empty() && o.converged_degree > 0 && !o.converged_cases.empty())
      {
        const fem::TetMesh finer = fem::read_gmsh(o.converged_mesh);
        check_same_body(fem::read_gmsh(body.mesh_file).vertices, finer.vertices,
                        "--converged-mesh '" + o.converged_mesh + "'");
        if (free_surface_vertices(finer, body.fixed_surfaces).empty())
          throw InputError("--converged-mesh '" + o.converged_mesh + "' has no free surface");
      }
    else if (o.converged_degree == 1 && !o.converged_cases.empty())
      throw InputError("--converged-degree 1 on the scene's own mesh is the truth itself: give "
                       "--converged-mesh, or degree 2");
    PlaneModels m;
    // The reduced models first: a bad file is refused before the long precomputes.
    for (const auto &file : o.reduced_models)
      {
        const std::string name = "reduced_" + fs::path(file).stem().string();
        if (std::find(m.reduced_names.begin(), m.reduced_names.end(), name) != m.reduced_names.end())
          throw InputError("--reduced-model: two files named '" + fs::path(file).stem().string() +
                           "' would be one method, " + name + "; rename one");
        m.reduced.push_back(load_reduced_nonlinear_model(file, body.time_step));
        if (m.reduced.back().rigid_modes > 0)
          throw InputError("--reduced-model '" + file + "' is a free body's model (rigid modes in "
                           "its basis): the free cases take it (validate-free, validate-nonlinear)");
        m.reduced_names.push_back(name);
      }
    prepare_virtual_dofs(body, o, m, log);
    prepare_vertex_model(body, o, m, log);
    m.contact.margin         = o.margin;
    m.contact.max_candidates = o.max_candidates;
    // The FEM penalty's per-vertex equivalent needs the mean lumped area of the free vertices.
    m.mean_vertex_area = mean_free_vertex_area(m.vertex);
    return m;
  }

  CaseResult
  run_case(const Case &c, const fem::Scene &body, const PlaneModels &models,
           const PlaneValidationOptions &o, std::vector<unsigned> &fem_order, std::ostream &log)
  {
    CaseResult result;
    Row       &row = result.row;
    row.c          = c;
    row.on_dome    = c.turn_times.empty();
    for (const auto &d : c.d)
      {
        double best_dot = -1;
        for (const auto &dk : models.vdof.directions)
          best_dot = std::max(best_dot, dot(dk, d));
        row.on_dome = row.on_dome && best_dot > 1 - 1e-12;
      }
    Truth truth{c, models, body.time_step, {}, 0, nullptr, 0, nullptr};
    run_truth(truth, body, row, log);
    if (o.converged_degree > 0 &&
        std::find(o.converged_cases.begin(), o.converged_cases.end(), c.name) != o.converged_cases.end())
      run_converged_truth(truth, o, row, log);
    if (fem_order.empty())
      {
        std::map<long long, unsigned> at;
        for (unsigned i = 0; i < truth.run->surface.node_tags.size(); ++i)
          at[truth.run->surface.node_tags[i]] = i;
        for (const long long tag : models.vertex.output_node_tags)
          fem_order.push_back(at.at(tag));
      }
    for (const auto mapping : {OrientationMapping::nearest, OrientationMapping::interpolated})
      {
        run_virtual_dofs(row.method[mapping == OrientationMapping::nearest ? 0 : 1], truth, row,
                         mapping, 0);
        log << " ." << std::flush;
      }
    const double penalty = truth.run->plane_penalty.at(truth.scene.planes[0].name);
    row.vertex_stiffness = o.vertex_stiffness < 0 ? penalty * models.mean_vertex_area : o.vertex_stiffness;
    run_vertex_modal(row.method[2], truth, row, row.vertex_stiffness, fem_order);
    log << " ." << std::flush;
    if (o.direct)
      {
        PointInteraction run(models.vertex, 0, models.contact);
        run_vertex_contact(run, row.method[3], truth, row, row.vertex_stiffness, fem_order);
      }
    if (c.d.size() == 1 && c.turn_times.empty())
      run_virtual_dofs(row.same_contact, truth, row, OrientationMapping::interpolated_same_contact, 0);
    run_linear_references(row, truth, o.corotational, log);
    for (size_t k = 0; k < models.reduced.size(); ++k)
      {
        row.reduced.emplace_back(models.reduced_names[k], MethodResult());
        row.reduced_cut_failed.emplace_back();
        run_reduced(row.reduced.back().second, row.reduced_cut_failed.back(), truth, row,
                    models.reduced[k], penalty, o.reduced_newton_tolerance);
        log << " " << models.reduced_names[k] << " " << 100 * row.reduced.back().second.force_error
            << " % force, " << 100 * row.reduced.back().second.displacement_error << " % shape ("
            << row.reduced_cut_failed.back()[0] << " steps cut, " << row.reduced_cut_failed.back()[1]
            << " not converged);" << std::flush;
      }
    if (o.perturbations > 0)
      {
        run_perturbed(row, truth, o, fem_order);
        log << " perturbed" << std::flush;
      }
    if (std::find(o.sweep_cases.begin(), o.sweep_cases.end(), c.name) != o.sweep_cases.end())
      {
        result.sweep = run_stiffness_sweep(truth, row, o, penalty, fem_order);
        log << " sweep" << std::flush;
      }
    if (c.d.size() == 1)
      row.open_loop_displacement_error = open_loop_displacement_error(truth, row);
    log << " impulse error: vdof " << 100 * row.method[1].impulse_error << " %, vertex "
        << 100 * row.method[2].impulse_error << " %; force error: vdof "
        << 100 * row.method[1].force_error << " %, vertex " << 100 * row.method[2].force_error
        << " % (" << row.method[2].contact_vertices_max << " vertices, "
        << row.method[2].force_us << " us/step)\n";
    return result;
  }

  std::vector<MappingRow>
  mapping_rows(const std::vector<Row> &rows, const VirtualDofModel &model)
  {
    const auto support_vertex = [&](const Vec3 &d) { return surface_support(model, d).vertex; };
    std::vector<MappingRow> mapping;
    for (const auto &r : rows)
      {
        if (r.c.d.size() != 1 || !r.c.turn_times.empty())
          continue;
        MappingRow mr;
        mr.name          = r.c.name;
        mr.row           = &r;
        const auto near  = orientation_weights(model, r.c.d[0], OrientationMapping::nearest);
        const auto blend = orientation_weights(model, r.c.d[0], OrientationMapping::interpolated);
        const unsigned        own = support_vertex(r.c.d[0]);
        std::vector<unsigned> firsts;
        for (unsigned i = 0; i < blend.n; ++i)
          {
            if (!(blend.w[i] > 0))
              continue; // on a dome direction the blend is that one virtual DOF
            const unsigned v = support_vertex(model.directions[blend.k[i]]);
            if (std::find(firsts.begin(), firsts.end(), v) == firsts.end())
              firsts.push_back(v);
            const auto &x = model.coordinates[v], &y = model.coordinates[own];
            mr.spread = std::max(mr.spread, std::sqrt((x[0] - y[0]) * (x[0] - y[0]) +
                                                      (x[1] - y[1]) * (x[1] - y[1]) +
                                                      (x[2] - y[2]) * (x[2] - y[2])));
          }
        mr.distinct_first_contacts = static_cast<unsigned>(firsts.size());
        double c0 = 0, cs = 0;
        for (unsigned i = 0; i < blend.n; ++i)
          for (unsigned l = 0; l < blend.n; ++l)
            for (unsigned t = 0; t < model.length; ++t)
              {
                const double y = blend.w[i] * blend.w[l] * model.Y(blend.k[l], t, blend.k[i]);
                cs += y;
                if (t == 0)
                  c0 += y;
              }
        double n0 = 0, ns = 0;
        for (unsigned t = 0; t < model.length; ++t)
          {
            const double y = model.Y(near.k[0], t, near.k[0]);
            ns += y;
            if (t == 0)
              n0 += y;
          }
        mr.feedthrough_ratio = c0 / n0;
        mr.static_ratio      = cs / ns;
        mapping.push_back(mr);
      }
    return mapping;
  }
} // namespace irdm::validation::planes
