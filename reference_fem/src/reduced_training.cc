// A reduced model's cubature trained on FEM snapshots (reduced_model.h): the neo-Hookean FEM
// pressed by rigid planes, each snapshot projected on the basis. Plain C++ over the FEM's
// public API (no deal.II here).
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/reduced_model.h>

#include <irdm_common/error.h>

#include <Eigen/Dense>

#include <chrono>
#include <cmath>

namespace irdm::fem
{
  namespace
  {
    // The scene's body, material, damping, integrator and step, pressed by one plane from
    // rest: its own loads, probes, planes and outputs left out, every vertex's displacement
    // kept every `every` steps.
    Scene
    press_scene(const Scene &body, const TrainingPress &p, const FemTrainingOptions &o)
    {
      Scene s            = body;
      s.kinematics       = Kinematics::nonlinear;
      s.small_strain_law = s.body_frame_law = s.corotational_law = false;
      s.initial          = InitialState::rest;
      s.initial_velocity = s.initial_angular_velocity = {0, 0, 0};
      s.gravity_enabled  = false;
      s.vertex_forces.clear();
      s.surface_forces.clear();
      s.prescribed.clear();
      s.probes.clear();
      s.duration = 2 * o.ramp_steps * s.time_step;
      RigidPlane plane;
      plane.name   = "training";
      plane.normal = {-p.direction[0], -p.direction[1], -p.direction[2]};
      const auto at = [&](const double depth) {
        return Vec3{(p.support - depth) * p.direction[0], (p.support - depth) * p.direction[1],
                    (p.support - depth) * p.direction[2]};
      };
      plane.position.times  = {0, o.ramp_steps * s.time_step};
      plane.position.values = {at(0), at(p.depth)};
      s.planes              = {plane};
      s.outputs             = Scene::Outputs{};
      s.outputs.hdf5 = s.outputs.csv = false;
      s.outputs.field                = true;
      s.outputs.every                = o.every;
      return s;
    }
  } // namespace

  FemTrainingStates
  fem_training_states(const Scene &scene, const std::vector<double> &basis, const unsigned r,
                      const std::vector<TrainingPress> &presses, const FemTrainingOptions &o)
  {
    const auto t0 = std::chrono::steady_clock::now();
    if (r == 0 || basis.size() % r != 0)
      throw InputError("FEM training: the basis is not a whole number of rows of r fields");
    if (o.ramp_steps == 0 || o.every == 0)
      throw InputError("FEM training needs a ramp and a snapshot interval of at least one step");
    const Eigen::Index n = static_cast<Eigen::Index>(basis.size() / r);
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> U(
      basis.data(), n, r);
    FemTrainingStates out;
    for (size_t k = 0; k < presses.size(); ++k)
      {
        const NonlinearElasticity fem(press_scene(scene, presses[k], o));
        if (static_cast<Eigen::Index>(fem.n_dofs()) != n)
          throw InputError("FEM training: the basis has " + std::to_string(n) + " rows, the mesh " +
                           std::to_string(fem.n_dofs()) + " DoFs");
        // Each snapshot as it comes (a batch of one), so that a press Newton gives up on
        // keeps the states before it.
        const SampleSink project = [&](const RunResult &batch) {
          for (size_t j = 0; j < batch.time.size(); ++j)
            {
              // The rest state trains nothing; the run's last step is recorded even off the
              // snapshot interval, where the reduced model's training keeps none.
              const long step = std::lround(batch.time[j] / scene.time_step);
              if (step == 0 || step % o.every != 0)
                continue;
              const std::vector<double> &u = batch.field_displacement[j];
              const std::vector<double>   Mu_ = fem.mass_product(u);
              const Eigen::Map<const Eigen::VectorXd> uu(u.data(), n), Mu(Mu_.data(), n);
              const Eigen::VectorXd q = U.transpose() * Mu;
              // ||u - U q||_M^2 = u'Mu - q'q (U'MU = I).
              const double uMu = uu.dot(Mu);
              if (uMu > 0)
                out.largest_projection_error = std::max(
                  out.largest_projection_error, std::sqrt(std::max(0.0, uMu - q.squaredNorm()) / uMu));
              out.states.emplace_back(q.data(), q.data() + q.size());
            }
        };
        try
          {
            out.cut_steps += fem.run({}, project, 1).cut_steps;
          }
        catch (const InputError &e)
          {
            ++out.failed_presses;
            if (o.log)
              o.log(std::string("FEM training press failed (its earlier states kept): ") + e.what());
          }
        if (o.log)
          o.log("FEM training press " + std::to_string(k + 1) + " of " + std::to_string(presses.size()) +
                ": " + std::to_string(1e3 * presses[k].depth) + " mm, " +
                std::to_string(out.states.size()) + " states so far");
      }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }
} // namespace irdm::fem
