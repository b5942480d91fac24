// The plane study's device-held plate (plane_runs.h): virtual coupling through a spring and a
// damper (contact::Coupling), IRDM's vertex contact against the linear FEM with the same
// coupling, and the passivity observer on each (scene_runs.h).
#include "plane_runs.h"

#include <irdm/vertex_contact.h>
#include <reference_fem/elastodynamics.h>

#include <cmath>

namespace irdm::validation::planes
{
  namespace
  {
    /// The device: 5 mm past first contact at 0.1 m/s, back out by 0.1 s, then 1 cm away.
    struct Device
    {
      Vec3                d, normal;
      double              surface_at; // m, the free surface's support along d
      std::vector<double> times = {0, 0.05, 0.1, 0.15, 0.3}, pen = {0, 0.005, 0, -0.01, -0.01};

      Vec3
      at(const double t) const
      {
        const double w = surface_at - interp(times, pen, t);
        return Vec3{w * d[0], w * d[1], w * d[2]};
      }
    };

    /// The linear FEM holding the plate through the coupling (k, b) at tau / refine; forces
    /// kept at every refine-th step.
    Series
    fem_plate(const fem::Scene &body, const Device &device, const double k, const double b,
              const unsigned refine)
    {
      fem::Scene ls      = body;
      ls.kinematics      = fem::Kinematics::linear;
      ls.name            = "plate";
      ls.time_step       = body.time_step / refine;
      ls.duration        = device.times.back();
      ls.outputs.surface = false;
      fem::RigidPlane plate;
      plate.name               = "plate";
      plate.normal             = device.normal;
      plate.coupling_stiffness = k;
      plate.coupling_damping   = b;
      for (const double t : device.times)
        {
          plate.position.times.push_back(t);
          plate.position.values.push_back(device.at(t));
        }
      ls.planes    = {plate};
      const auto r = fem::ElasticDynamics(ls).run();
      Series     out;
      out.force.emplace_back();
      for (unsigned i = 1; i <= r.n_steps; ++i)
        {
          const double t = i * ls.time_step;
          const Vec3  &f = r.plane_force.at("plate")[i];
          observe_device_work(out, f, device.at(t), device.at(t - ls.time_step));
          if (i % refine == 0)
            out.force.back().push_back(f);
        }
      return out;
    }

    /// Vertex contact from the modal model holding the plate through the coupling (k, b).
    Series
    irdm_plate(const PlaneModels &models, const double tau, const Device &device, const double k,
               const double b)
    {
      const contact::Coupling coupling{k, b};
      ModalInteraction        run(models.modal, models.contact);
      Series                  out;
      out.force.emplace_back();
      Vec3 plate = device.at(0);
      for (unsigned n = 1; n * tau <= device.times.back() + 1e-12; ++n)
        {
          const double t = n * tau;
          PlaneTarget  target;
          target.normal              = device.normal;
          target.coupling_compliance = coupling.compliance(tau);
          target.point = coupling.target(device.at(t), device.at(t - tau), plate, tau);
          if (!run.step(&target, 1))
            {
              out.diverged_at = t;
              break;
            }
          const Vec3 f = run.vertex_contact().plane(0).force;
          for (int e = 0; e < 3; ++e)
            plate[e] = target.point[e] - target.coupling_compliance * f[e];
          observe_device_work(out, f, device.at(t), device.at(t - tau));
          out.force.back().push_back(f);
        }
      return out;
    }
  } // namespace

  PlateStudy
  run_plate_study(const fem::Scene &body, const PlaneModels &models, const Vec3 &side,
                  std::ostream &log)
  {
    log << "device-held plate" << std::flush;
    const double tau = body.time_step;
    const Vec3   normal{-side[0], -side[1], -side[2]};
    const Device device{side, normal,
                        dot(side, models.vdof.coordinates[surface_support(models.vdof, side).vertex])};
    PlateStudy   study;
    study.grid = {{0, 0},    {30, 0},   {30, 0.5},  {300, 0},  {300, 0.5},
                  {3000, 0}, {3000, 0.5}, {30000, 0}, {30000, 0.5}};
    for (const auto &[k, b] : study.grid)
      {
        study.runs.push_back({k, b, tau, "irdm_vertex_contact_modal", irdm_plate(models, tau, device, k, b)});
        study.runs.push_back({k, b, tau, "fem", fem_plate(body, device, k, b, 1)});
        study.runs.push_back({k, b, tau / 10, "fem", fem_plate(body, device, k, b, 10)});
        const auto n = study.runs.size();
        study.exactness.push_back(compare(study.runs[n - 3].s, study.runs[n - 2].s).force_rel_l2);
        log << "." << std::flush;
      }
    log << "\n";
    study.rigid_peak = peak_force(study.runs[1].s);
    return study;
  }
} // namespace irdm::validation::planes
