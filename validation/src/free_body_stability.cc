// The free-body study's stability runs (free_body_runs.h): the runtime alone, rolling on the
// floor for a long time by each method, and in free flight.
#include "free_body_runs.h"
#include "scene_runs.h"

#include <irdm_common/format.h>

#include <chrono>
#include <cmath>
#include <type_traits>

namespace irdm::validation::free_body
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    /// The rolling cat (spin_roll's start) on the floor for o.stability_seconds; traced every
    /// 0.1 s into stability.csv.
    template <class Runtime>
    void
    roll_for_long(Runtime &irdm, const char *method, const Material &m, FreeStudy &study,
                  std::ostream &log)
    {
      const Case roll   = rolling_case();
      double     lowest = 1e300;
      for (const auto &X : m.rest)
        lowest = std::min(lowest, X(2));
      const FreeBodyOptions fo;
      irdm.rigid().set_velocity(roll.velocity, roll.spin);
      PlaneTarget floor;
      floor.normal  = {0, 0, 1};
      floor.point   = {0, 0, lowest - roll.height};
      floor.penalty = m.floor_penalty;
      EnergyWatch<Runtime> watch{irdm, fo.gravity};
      watch.start(roll.height);
      const unsigned steps = static_cast<unsigned>(std::lround(m.o.stability_seconds / m.tau));
      const unsigned trace_every = std::max(1u, static_cast<unsigned>(std::lround(0.1 / m.tau)));
      double         growth = 0, turned = 0, seconds = 0, deepest = 0;
      unsigned       failed = 0;
      Eigen::Matrix3d R_prev = Eigen::Matrix3d::Identity();
      // The surface (deformed, placed by the pose) at the trace's samples: how far its lowest
      // vertex is below the floor (a contact that holds keeps it near the penalty's give).
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
          if (step % trace_every != 0)
            continue;
          int active = 0;
          if constexpr (std::is_same_v<Runtime, FreeBodyInteraction>)
            active = irdm.deformation().plane_result(0).active;
          irdm.surface_positions(x.data());
          double below = 0;
          for (unsigned v = 0; v < nv; ++v)
            below = std::max(below, floor.point[2] - x[3 * v + 2]);
          deepest = std::max(deepest, below);
          study.stability_csv << material_name(m.E) << ',' << method << ',' << step * m.tau << ','
                              << watch.growth() << ','
                              << irdm.deformation().elastic_energy() / watch.e_in << ','
                              << turned << ',' << active << ',' << below << '\n';
        }
      study.stability.push_back({"rolling, " + plain(m.o.stability_seconds) + " s", method, m.E, growth, turned, watch.growth(),
                                 1e3 * deepest, 1e6 * seconds / steps, failed, false,
                                 irdm.limited_steps()});
      if constexpr (std::is_same_v<Runtime, FreeBodyInteraction>)
        {
          const VertexContact &contact = irdm.deformation().interaction().vertex_contact();
          study.stability.back().contact_limited  = contact.limited_steps();
          study.stability.back().contact_fallback = contact.fallback_steps();
        }
      log << "validate-free: " << m.o.stability_seconds << " s rolling, " << method
          << ": largest energy gain " << growth << " of the energy brought in, turned " << turned
          << " deg, " << failed << " failed steps" << std::endl;
    }

    /// A reduced nonlinear model rolling as roll_for_long's runtime does: its energy (kinetic,
    /// strain, gravity's) against its start, traced into stability.csv. Newton's failures are
    /// its failed steps (the steps cut back are in the log).
    void
    roll_reduced_for_long(const ReducedModelOfBody &r, const Material &m, FreeStudy &study, std::ostream &log)
    {
      const Case roll   = rolling_case();
      double     lowest = 1e300;
      for (const auto &X : m.rest)
        lowest = std::min(lowest, X(2));
      const Eigen::Vector3d g(0, 0, -9.81);
      ReducedBodyOptions    options;
      options.floating_frame        = r.floating;
      options.keep_angular_momentum = r.keep_angular_momentum;
      ReducedNonlinearBody body(r.model, options);
      if (!body.start({g(0), g(1), g(2)}, {roll.velocity(0), roll.velocity(1), roll.velocity(2)},
                      {roll.spin(0), roll.spin(1), roll.spin(2)}))
        throw std::logic_error("validate-free: the reduced model refused the roll's start");
      ReducedPlane floor;
      floor.normal  = {0, 0, 1};
      floor.point   = {0, 0, lowest - roll.height};
      floor.penalty = m.floor_penalty;
      const auto energy = [&] { return body.energy() - r.model.mass * g.dot(body.center_of_mass()); };
      const double e0 = energy(), e_in = body.energy() + r.model.mass * g.norm() * roll.height;
      const unsigned steps = static_cast<unsigned>(std::lround(m.o.stability_seconds / m.tau));
      const unsigned trace_every = std::max(1u, static_cast<unsigned>(std::lround(0.1 / m.tau)));
      double         growth = 0, turned = 0, seconds = 0, deepest = 0;
      Eigen::Matrix3d R_prev = Eigen::Matrix3d::Identity();
      // Angular momentum against the external torque's impulse (a floating body's): the floor
      // pushes along z only, so its torque has no z part, and the physics keeps L_z; the log
      // shows whether the reduced model does.
      AngularMomentumBalance balance;
      if (body.floating())
        balance.add(body, m.tau); // the start: nothing touches yet
      const size_t        S = r.model.surface_vertex.size();
      std::vector<double> u(3 * S);
      for (unsigned step = 1; step <= steps; ++step)
        {
          const auto t0 = Clock::now();
          body.step(&floor, 1);
          seconds += std::chrono::duration<double>(Clock::now() - t0).count();
          if (body.floating())
            balance.add(body, m.tau);
          growth = std::max(growth, (energy() - e0) / e_in);
          turned += angle_deg(body.frame_rotation() * R_prev.transpose());
          R_prev = body.frame_rotation();
          if (step % trace_every != 0)
            continue;
          body.surface_displacement(u.data());
          double below = 0;
          for (size_t s = 0; s < S; ++s)
            below = std::max(below, floor.point[2] - (r.model.coordinates[s][2] + u[3 * s + 2]));
          deepest = std::max(deepest, below);
          study.stability_csv << material_name(m.E) << ',' << r.method << ',' << step * m.tau << ','
                              << (energy() - e0) / e_in << ',' << body.strain_energy() / e_in << ','
                              << turned << ',' << body.plane_vertices(0) << ',' << below << '\n';
        }
      study.stability.push_back({"rolling, " + plain(m.o.stability_seconds) + " s", r.method, m.E, growth,
                                 turned, (energy() - e0) / e_in, 1e3 * deepest, 1e6 * seconds / steps,
                                 static_cast<unsigned>(body.failed_steps()), false, 0});
      log << "validate-free: " << m.o.stability_seconds << " s rolling, " << r.method
          << ": largest energy gain " << growth << " of the energy brought in, at the end "
          << (energy() - e0) / e_in << ", turned " << turned << " deg (the frame's), "
          << body.failed_steps() << " steps not converged, " << body.cut_steps() << " cut" << std::endl;
      if (body.floating())
        log << "  angular momentum: at the start " << balance.first.transpose() << " kg m^2/s, at the end "
            << balance.last.transpose() << "; the external torque's impulse "
            << balance.impulse.transpose() << " N m s" << std::endl;
    }

    /// Free flight: no plane, 10 s, spinning about an axis off the principal ones. Without the
    /// spin's coupling the deformation stays zero and the energy is the rigid integrator's;
    /// with the centrifugal force alone the spin stretches the body, whose strain energy is not
    /// taken from the spin (the gain it shows); with the deformed inertia as well it is.
    void
    fly_free(const Material &m, const bool coupled, FreeStudy &study)
    {
      const FreeBodyOptions fo = coupled ? spin_options(m.o) : FreeBodyOptions{};
      FreeBodyInteraction   irdm(m.frame(), fo);
      const Eigen::Vector3d v0(0.3, -0.2, 1.0), w0(3, 8, -5);
      irdm.rigid().set_velocity(v0, w0);
      const Eigen::Vector3d p0 = irdm.rigid().state().linear_momentum,
                            L0 = irdm.rigid().state().angular_momentum;
      EnergyWatch<FreeBodyInteraction> watch{irdm, fo.gravity};
      watch.start(0);
      const unsigned steps = static_cast<unsigned>(std::lround(10.0 / m.tau));
      double         dp = 0, dL = 0, growth = 0;
      for (unsigned step = 1; step <= steps; ++step)
        {
          irdm.step(nullptr, 0);
          const Eigen::Vector3d p = p0 + m.mass * fo.gravity * (step * m.tau);
          dp     = std::max(dp, (irdm.rigid().state().linear_momentum - p).norm() / p0.norm());
          dL     = std::max(dL, (irdm.rigid().state().angular_momentum - L0).norm() / L0.norm());
          growth = std::max(growth, watch.growth());
        }
      const std::string what =
        !coupled ? ""
        : fo.centrifugal && fo.deformed_inertia ? ", with the centrifugal force and the deformed inertia"
        : fo.centrifugal                        ? ", with the centrifugal force"
        : fo.deformed_inertia                   ? ", with the deformed inertia"
                                                : "";
      const std::string frame = std::string(coupled && fo.frame_forces() ? " and the frame's forces" : "") +
                                (coupled && fo.deformation_momentum ? " and the deformation's momentum" : "");
      study.stability.push_back({"free flight, 10 s" + what + frame,
                                 coupled ? m.models.back().method : "either (no contact)", m.E,
                                 growth, 0, 0, 0, 0, 0, true});
      study.free_flight.push_back({material_name(m.E), what + frame, dp, dL, growth,
                                   irdm.deformation().elastic_energy()});
    }
  } // namespace

  void
  run_stability(const Material &m, FreeStudy &study, std::ostream &log)
  {
    for (size_t r = 0; r < m.models.size() && m.floor_penalty > 0; ++r)
      if (!m.models[r].impact_study_only)
        {
          FreeBodyInteraction irdm(m.models[r].model, spin_options(m.o));
          roll_for_long(irdm, m.models[r].method.c_str(), m, study, log);
        }
    if (m.vdof && m.floor_penalty > 0)
      {
        FreeBodyVirtualDofs irdm(*m.vdof, FreeBodyOptions());
        roll_for_long(irdm, vdof_method, m, study, log);
      }
    for (size_t r = 0; r < m.reduced.size() && m.floor_penalty > 0; ++r)
      roll_reduced_for_long(m.reduced[r], m, study, log);
    for (const bool coupled : {false, true})
      if (!coupled || m.o.centrifugal || m.o.deformed_inertia || m.o.frame_forces ||
          m.o.deformation_momentum)
        fly_free(m, coupled, study);
  }
} // namespace irdm::validation::free_body
