#pragma once
// Internal to validation/: the free-body study's cases (free_body_cases.cc), its runner (every
// case through the nonlinear FEM, the linear FEM and every runtime method: free_body_runs.cc;
// the runtime alone for long: free_body_stability.cc), and its report writer
// (free_body_report.cc).
#include <irdm/free_body.h>
#include <irdm/modal_model.h>
#include <irdm/plane_interaction.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm_common/rigid_fit.h>
#include <reference_fem/scene.h>
#include <validation/free_body_validation.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace irdm::validation::free_body
{
  /// One case: the floor's normal (world = the mesh's frame; gravity is -9.81 along it), the
  /// drop height (gap between the body's lowest point and the floor), the initial velocity
  /// and spin, and an optional wall along +x.
  struct Case
  {
    std::string     name;
    Eigen::Vector3d up     = Eigen::Vector3d::UnitZ();
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

  /// Dropped 2 cm spinning at 8 rad/s about y: it rolls over within 2 s.
  Case
  rolling_case();

  /// Whether the options run the impact study (a full run, or one that names it).
  bool
  runs_impact_study(const FreeBodyValidationOptions &o);

  /// The cases the options choose, the impact study's last.
  std::vector<Case>
  chosen_cases(const FreeBodyValidationOptions &o);

  /// "2kPa", "50kPa".
  std::string
  material_name(double E);

  double
  angle_deg(const Eigen::Matrix3d &R);

  /// One run, the FEM's (sampled at tau) or the runtime's, as the error measures take it: at
  /// every step of tau (index 1..n; 0 unused) the total plane force, its impulse over the step,
  /// the centre of mass and the surface's best-fit pose and deformation.
  struct Samples
  {
    std::vector<Eigen::Vector3d> force, impulse, com;
    std::vector<RigidFit>        fit;
    explicit Samples(unsigned n);
    unsigned
    steps() const
    {
      return static_cast<unsigned>(force.size() - 1);
    }
  };

  /// A run's errors against a reference run: over the whole run, and over the steps
  /// [window_begin, window_end) (the first contact). com: the largest distance between the
  /// paths over the distance the reference travelled; angle: the largest angle between the
  /// best-fit rotations (deg); force and deformation: relative L2; impulse: the total's
  /// relative error.
  struct RunErrors
  {
    double com = 0, angle = 0, force = 0, impulse = 0, deformation = 0, distance = 0;
    double window_force = 0, window_impulse = 0, window_deformation = 0;
  };

  RunErrors
  compare(const Samples &reference, const Samples &run, const Eigen::Vector3d &c0,
          unsigned window_begin, unsigned window_end);

  /// The converged truth's method name: fem_neo_hookean_p<degree>, with _<mesh file stem> on a
  /// finer mesh (FreeBodyValidationOptions::converged_mesh).
  std::string
  converged_truth_name(const FreeBodyValidationOptions &o);

  /// One row of free.csv and first_contact.csv: a case, material and method.
  struct Row
  {
    std::string c, method;
    double      E = 0;
    double      com_error = 0, angle_error = 0, force_error = 0, impulse_error = 0,
           deformation_error = 0, irdm_us = 0, fem_ms = 0, peak_ratio = 0, rotation_deg = 0,
           turned_deg = 0, centrifugal = 0, energy_growth = 0;
    bool        stable = true;
    double      impact_speed = 0; // m/s: a row of the impact study (impact.csv), not free.csv
    std::string fem_failed;       // the FEM's error message when it could not run the case
    // The first contact alone (the FEM's first step with a plane force to its first step
    // without, after it): before the paths can part at a later bounce.
    double first_start = 0, first_end = 0, first_force_error = 0, first_impulse_error = 0,
           first_deformation_error = 0;
    // Against the linear FEM over the whole run (the method's own error); NaN: not run.
    double method_force_error = std::nan(""), method_impulse_error = std::nan(""),
           method_deformation_error = std::nan("");
  };

  /// One row of linearization.csv: a run against a reference over the first contact and the
  /// whole run (method error and linearization apart).
  struct LinearizationRow
  {
    std::string c, method, reference;
    double      E = 0, start = 0, end = 0, rotation_deg = 0;
    double      impact_speed = 0; // m/s: the impact study's (impact.csv)
    RunErrors   errors;
    std::string failed; // the linear FEM's error message when it could not run
    double      fem_ms = 0; // the run's cost per step of tau (ms), 0 when not the run's own
  };

  /// How far the truth is from small strain in one case (truth_strain.csv): the largest
  /// principal stretch departure and the volume fraction past 10 %, over the first contact and
  /// the whole run (RunResult::largest_strain).
  struct StrainRow
  {
    std::string c;
    double      E = 0, start = 0, end = 0, impact_speed = 0;
    double      first_largest = 0, first_fraction = 0, run_largest = 0;
  };

  /// The truth's own determination (--truth-check): the FEM at tau / 2M against tau / M.
  struct TruthRow
  {
    std::string c;
    double      E = 0;
    RunErrors   errors{};
    double      half_ms = 0; // the half-step run's cost per step of tau
    std::string failed{};
  };

  /// The runtime alone: a long roll, or free flight.
  struct StabilityRow
  {
    std::string run, method;
    double      E = 0, growth = 0, turned = 0, final_growth = 0, deepest = 0, us = 0;
    unsigned    failed = 0;
    bool        flight = false;
    unsigned long limited = 0; // steps whose deformed inertia was limited (FreeBody::limited_steps)
    // Many-vertex contact's fallbacks (VertexContact::limited_steps, fallback_steps).
    unsigned long contact_limited = 0, contact_fallback = 0;
  };

  /// A free flight's conservation: what the report lists.
  struct FreeFlight
  {
    std::string material, what; // what: the coupling terms on ("" none)
    double      momentum = 0, angular_momentum = 0, growth = 0, elastic_energy = 0;
  };

  /// Everything the study measured, as the report writer receives it; the long series are kept
  /// as the CSV text they go to.
  struct FreeStudy
  {
    std::vector<Row>              rows;
    std::vector<LinearizationRow> linearization;
    std::vector<StrainRow>        strain;
    std::vector<TruthRow>         truth;
    std::vector<StabilityRow>     stability;
    std::vector<FreeFlight>       free_flight;
    std::ostringstream            series, frames, stability_csv;
    std::vector<std::array<unsigned, 3>> triangles;
    FreeStudy();
  };

  /// The study's scene as read (each material's body is made from its text) and as parsed,
  /// the options checked against it; InputError naming `command` otherwise.
  struct BaseScene
  {
    std::string text;
    fem::Scene  scene;
  };

  BaseScene
  read_base_scene(const FreeBodyValidationOptions &o, const std::string &command);

  /// run_material for every material of o, each with its truth's step division.
  void
  run_materials(const FreeBodyValidationOptions &o, const std::string &base_text, FreeStudy &study,
                std::ostream &log);

  /// Runs every chosen case of one material (Young's modulus E, the truth at tau / M) through
  /// the FEM and every method, then the runtime alone for long; adds the results to `study`.
  void
  run_material(const FreeBodyValidationOptions &o, const std::string &base_text, double E,
               unsigned M, FreeStudy &study, std::ostream &log);

  /// The report's tables (Markdown rows), made with the CSV files they show.
  struct FreeTables
  {
    std::string free, first_contact, strain, linearization, impact, truth;
  };

  /// free.csv, first_contact.csv, truth_strain.csv, linearization.csv, impact.csv, series.csv,
  /// stability.csv, frames.csv, triangles.csv, truth.csv in dir; returns the report's tables.
  FreeTables
  write_free_csvs(const std::string &dir, const FreeBodyValidationOptions &o, const FreeStudy &s,
                  double density);

  /// The pictures validation/plot_free.py draws into the report folder.
  inline constexpr const char *charts[] = {"fig6.png", "frames.png", "impact.png", "stability.png"};

  /// report.md (validation/templates/free.md), showing the charts present in dir.
  void
  write_free_report(const std::string &dir, const FreeBodyValidationOptions &o,
                    const FreeStudy &s, const fem::Scene &base, const FreeTables &tables);
} // namespace irdm::validation::free_body

namespace irdm::validation::free_body
{
  /// Energy the runtime's body has above its start, less a probe's work on it, (E(t) - E(0) -
  /// W(t)) / E_in: E = rigid kinetic + deformation + gravity's potential; E_in = the initial
  /// kinetic energy plus the weight times the drop height plus the probe's work (its absolute
  /// value step by step), what the scene brings in. (Virtual DOFs: no deformation energy.)
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

  /// A modal realization and its free.csv method name.
  struct NamedModel
  {
    std::string method;
    ModalModel  model;
    bool        impact_study_only = false; // run on the impact study's cases alone
  };

  constexpr const char *vdof_method = "vdof_rigid_fit"; // the seed's virtual DOFs, route 1

  /// A reduced body's balance of angular momentum over a run of steps: its change against
  /// the external torque's impulse (the trapezoid of the steps' end torques, as the
  /// integrator takes a step's forces). What differs is the projected forces' own torque
  /// (the vertex forces'; the internal force's and the planes' too with the projected
  /// torques), the floating frame's carry and the integrator's own error.
  struct AngularMomentumBalance
  {
    bool            started = false;
    Eigen::Vector3d first = Eigen::Vector3d::Zero(), last = Eigen::Vector3d::Zero();
    Eigen::Vector3d impulse = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();

    // The state after a step: the first call marks the start (its torque is the step's end
    // one, the trapezoid's first point).
    void
    add(const ReducedNonlinearBody &body, const double tau)
    {
      const Eigen::Vector3d L = body.angular_momentum(), t = body.external_torque();
      if (started)
        impulse += 0.5 * tau * (torque + t);
      else
        first = L, started = true;
      last = L, torque = t;
    }
    // "changed by |dL|, the torque's impulse |J|, their difference |dL - J|".
    std::string
    text() const;
  };

  /// A reduced nonlinear model of the free body and its free.csv method name; order[v]: the
  /// model's surface index of the comparison's vertex v.
  struct ReducedModelOfBody
  {
    std::string           method;
    ReducedNonlinearModel model;
    std::vector<unsigned> order;
    bool                  floating = true; // ReducedBodyOptions::floating_frame
    bool                  keep_angular_momentum = true; // ReducedBodyOptions'
  };

  /// Young's modulus (Pa) of a reduced model's law, from its Lame constants.
  double
  young_modulus(const ReducedNonlinearModel &model);

  /// One material's body and models, shared by its cases.
  struct Material
  {
    const FreeBodyValidationOptions &o;
    double                           E = 0;
    unsigned                         M = 1; // the truth runs at tau / M
    fem::Scene                       body{};
    double                           tau = 0;
    std::vector<NamedModel>          models{};
    // The comparison's vertices (the modal models' outputs), their rest positions, the centre
    // of mass, mass and radius of gyration.
    std::vector<Eigen::Vector3d> rest{};
    std::vector<long long>       node_tags{};
    std::vector<int>             output_input_index{};
    Eigen::Vector3d              c0 = Eigen::Vector3d::Zero();
    double                       mass = 0, r_gyration = 0;
    std::optional<VirtualDofModel> vdof{};
    std::vector<unsigned>          vdof_order{}; // the virtual-DOF surface's index of each vertex
    double                         floor_penalty = 0; // Pa/m: the FEM's, from its runs
    std::vector<ReducedModelOfBody> reduced{}; // --reduced-model files of this material

    const ModalModel &
    frame() const
    {
      return models.back().model;
    }
  };

  /// The runtime alone on one material: the rolling cat for a long run by each method, and free
  /// flight for 10 s (free_body_stability.cc).
  void
  run_stability(const Material &m, FreeStudy &study, std::ostream &log);

  /// The modal routes' runtime options from the study's: the spin's terms it asks for (no
  /// gravity), the same in every run (the cases, the rolls, the free flights).
  FreeBodyOptions
  spin_options(const FreeBodyValidationOptions &o);
} // namespace irdm::validation::free_body
