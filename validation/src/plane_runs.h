#pragma once
// Internal to validation/: the plane study's runner. Each case runs once through the nonlinear
// FEM (the truth) and through every method, which is scored against it (plane_runs.cc); the
// rows go to the report writer (plane_report.cc).
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/plane_interaction.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm/vertex_contact.h>
#include <reference_fem/scene.h>
#include <validation/plane_validation.h>

#include "plane_cases.h"
#include "scene_runs.h"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation::planes
{
  /// The methods compared, in report order.
  inline constexpr std::array<const char *, 4> method_names = {
    "vdof_nearest", "vdof_interpolated", "vertex_contact_modal", "vertex_contact_direct"};

  /// The smallest and largest of a figure over runs.
  struct Range
  {
    double lo = INFINITY, hi = -INFINITY;
    void
    add(const double x)
    {
      lo = std::min(lo, x), hi = std::max(hi, x);
    }
    bool
    empty() const
    {
      return lo > hi;
    }
  };

  /// One method's run of one case, scored against the truth.
  struct MethodResult
  {
    bool   ran       = false;
    double stiffness = 0;   // N/m: per vertex (vertex contact) or per virtual DOF; 0 rigid
    double force_error = 0; // relative L2 of the total wall force along -d, over the history
    // |sum F_IRDM - sum F_FEM| / sum F_FEM: the impulse the walls give, which bouncing
    // contact (chatter at a single vertex) does not scramble as the L2 does.
    double impulse_error        = 0;
    double displacement_error   = 0;  // relative L2 over surface and time
    int    contact_vertices_max = -1; // vertex contact: most vertices pushed at once
    int    candidates_max = -1, rounds_max = -1; // vertex contact: rows, solver rounds
    double max_penetration = 0; // m: vertex contact, deepest vertex past a wall; virtual
                                // DOFs, the band past a compliant wall (F / k)
    double force_us = 0, surface_us = 0;
    // Finite throughout, no failed step, and the surface within 10 times the FEM's largest
    // displacement (a run that blows up or locks up is not stable).
    bool                stable = true;
    std::vector<double> F; // per step k = 1..N, total force along -d (N)
    // Each error's range over this run and the runs with the walls perturbed by parts per
    // million (PlaneValidationOptions::perturbations; empty when none ran).
    Range force_range, impulse_range, displacement_range;
    // Against the converged truth (PlaneValidationOptions::converged_degree), the same
    // measures; -1 where it did not run.
    double converged_force_error = -1, converged_impulse_error = -1,
           converged_displacement_error = -1;
  };

  /// One case: the truth's figures and every method's.
  struct Row
  {
    Case   c;
    double fem_peak_force = 0, fem_max_penetration = 0;
    // The surface driven by the FEM's own wall force (open loop, interpolated mapping, one
    // wall): the error of the responses alone, without the contact solve's.
    double   open_loop_displacement_error = -1;
    bool     on_dome         = false; // every d is one of the model's directions
    double   fem_ms_per_step = 0;
    unsigned newton          = 0;
    double   largest_strain  = 0; // the truth's over the run (RunResult::largest_strain)
    std::vector<double>                           F_fem; // per step, total along -d
    std::array<MethodResult, method_names.size()> method;
    MethodResult same_contact; // virtual DOFs, interpolated_same_contact (one fixed wall)
    // The linear FEM with the same vertex contact (fixed walls): what any linear model with
    // this contact reaches, IRDM's exact reference (vertex_contact_direct equals it).
    MethodResult linear_fem;
    double       linear_fem_seconds = 0;
    // The nonlinear solver with the small-strain law and the truth's own penalty contact:
    // against the truth, what geometric and material nonlinearity cost; against linear_fem,
    // what lumped vertex contact at a uniform stiffness costs.
    MethodResult linear_law;
    double       linear_law_ms = 0; // its cost per step (ms), 0 when not run
    // PlaneValidationOptions::corotational: the nonlinear solver with the corotational law
    // and the truth's contact against the truth (the strain's share of the linear law's
    // miss), and the small-strain law against it (the rotation's share).
    MethodResult corotational, rotation;
    double       corotational_ms = 0;
    // PlaneValidationOptions::reduced_models, each by its method name (reduced_<stem>), and
    // each one's Newton steps cut back or failed over the case.
    std::vector<std::pair<std::string, MethodResult>> reduced;
    std::vector<std::array<unsigned long, 2>>        reduced_cut_failed;
    // The converged truth (PlaneValidationOptions::converged_degree, converged_mesh) where it
    // ran: its name (converged_truth_name), degree, free DoFs, cost per step and peak force
    // (N), and the P1 truth against it (the truth's own discretization error; -1 where it did
    // not run). On another mesh: the largest distance from this truth's surface vertices to
    // that mesh's surface (m), where its displacement is taken.
    std::string converged_truth;
    double   converged_peak_force = 0, converged_surface_gap = 0;
    unsigned converged_degree = 0, converged_dofs = 0;
    double   converged_ms = 0, truth_force_error = -1, truth_impulse_error = -1,
             truth_displacement_error = -1;
    double       vertex_stiffness = 0; // N/m, of vertex contact's walls in the table
  };

  /// A compliant wall of the stiffness sweep.
  struct SweepRow
  {
    std::string  c, method;
    double       k;
    bool         fem_equivalent; // k is the FEM penalty's per-vertex equivalent
    MethodResult result;
  };

  /// The models every case runs on: virtual DOFs, and the vertex-contact model (every free
  /// surface vertex an input and an output) with its modal realization.
  struct PlaneModels
  {
    VirtualDofModel      vdof;
    double               seconds_per_orientation = 0; // mean FEM time per orientation
    ImpulseResponseModel vertex;
    bool                 vertex_reused             = false;
    double               vertex_precompute_seconds = 0;
    ModalModel           modal;
    VertexContactOptions contact;
    double               mean_vertex_area = 0; // m^2, of the free surface vertices
    // PlaneValidationOptions::reduced_models, loaded, and their method names.
    std::vector<ReducedNonlinearModel> reduced;
    std::vector<std::string>           reduced_names;
  };

  /// The body every case runs on: the scene's mesh and material, nothing but the walls acting
  /// on it (probes, prescribed motion and gravity dropped), nonlinear, the surface recorded.
  fem::Scene
  grounded_body(const std::string &scene);

  /// The converged truth's method name: fem_neo_hookean_p<degree> on the scene's own mesh,
  /// fem_neo_hookean_p<degree>_<mesh file stem> on PlaneValidationOptions::converged_mesh.
  std::string
  converged_truth_name(const PlaneValidationOptions &o);

  /// Makes the models (or reuses those made from this scene with this spec; a file at either
  /// path that is not is refused, never overwritten). A converged mesh that cannot carry the
  /// body (unreadable, or without its fixed surfaces) is refused first.
  PlaneModels
  prepare_models(const fem::Scene &body, const PlaneValidationOptions &o, std::ostream &log);

  /// Everything one case adds to the study.
  struct CaseResult
  {
    Row                   row;
    std::vector<SweepRow> sweep; // on the sweep's cases
  };

  /// Runs one case through the truth and every method. `fem_order` maps the vertex model's
  /// outputs to the FEM's surface vertices (filled from the first case's run).
  CaseResult
  run_case(const Case &c, const fem::Scene &body, const PlaneModels &models,
           const PlaneValidationOptions &o, std::vector<unsigned> &fem_order, std::ostream &log);

  /// The device-held plate (virtual coupling) at every setting of the grid.
  struct PlateStudy
  {
    std::vector<std::pair<double, double>> grid;      // (k N/m, b N s/m); (0, 0) rigid
    std::vector<CouplingRun>               runs;      // per grid point: IRDM, FEM tau, FEM tau/10
    std::vector<double>                    exactness; // per grid point, IRDM against FEM at tau
    double                                 rigid_peak = 0; // N, the rigid plate's FEM peak
  };

  /// A device taps the side holding a plate through a spring and a damper: vertex contact
  /// from the modal model at the model's step, against the linear FEM with the same coupling
  /// at that step (exact) and at a tenth of it (the step's effect).
  PlateStudy
  run_plate_study(const fem::Scene &body, const PlaneModels &models, const Vec3 &side,
                  std::ostream &log);

  /// Why interpolating between orientations can be worse than the nearest one, per one-wall
  /// fixed case: the three virtual DOFs the interpolation blends, how far apart their
  /// first-contact vertices are, and the blend's feed-through and static compliance against
  /// the nearest virtual DOF's.
  struct MappingRow
  {
    std::string name;
    double      spread = 0, feedthrough_ratio = 0, static_ratio = 0;
    unsigned    distinct_first_contacts = 0;
    const Row  *row = nullptr;
  };

  std::vector<MappingRow>
  mapping_rows(const std::vector<Row> &rows, const VirtualDofModel &model);

  /// A whole run of the study, as the report writer receives it.
  struct PlaneStudy
  {
    const PlaneValidationOptions &options;
    const fem::Scene             &body;
    const PlaneModels            &models;
    Directions                    directions;
    std::vector<Row>              rows;
    std::vector<SweepRow>         sweep;
    PlateStudy                    plate;
    std::vector<MappingRow>       mapping;
  };

  /// planes.md (validation/templates/planes.md), planes.csv, cases.csv, forces.csv,
  /// stiffness.csv, mapping.csv and coupling.csv in dir.
  void
  write_plane_report(const std::string &dir, const PlaneStudy &study);
} // namespace irdm::validation::planes
