#pragma once
// A second compressor: the modal (state-space) realization of H. The precompute's H is exactly
//   H_kj[s] = sum_i phi_i(j) phi_i(k) q_i[s],
// q_i the response of mode i to the FEM's own integrator step (irdm/model.h, ModalData).
// The state of every mode is 3 numbers and one step matrix; carrying all of them costs O(N)
// per step, independent of T and of the number of outputs. So:
//   - the force loop uses every mode: the contact force is that of the exact model;
//   - the full surface update uses the lowest M modes, and the rest as a static correction
//     E = sum_s (H[s] - H_M[s]) applied to this step's force (dropped modes treated as
//     quasi-static), so the surface keeps H's static compliance exactly.
// Memory: shapes at the inputs for all modes, at the outputs for M modes (float), H[0] among the
// inputs, and E (inputs x outputs). Cost per step: O(N) + O(n_out M) + O(n_out n_active).
#include <irdm/irdm.h>
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm/rigid_body.h>

#include <array>
#include <vector>

namespace irdm
{
  struct ModalModelOptions
  {
    unsigned surface_modes = 100; // M lowest modes in the full surface update
    // K lowest modes in the force loop's history (0: every mode, the exact model). Fewer
    // make the force step cheaper; the modes beyond K then respond quasi-statically to the
    // step's force (their static compliance joins the feed-through). K >= M.
    unsigned force_modes = 0;
  };

  struct ModalModel : ModelFrame
  {
    unsigned            n_modes = 0, surface_modes = 0;
    unsigned            force_modes = 0; // K: modes in the force loop's history (<= n_modes)
    double              highest_frequency_hz = 0; // of the surface modes
    double              build_seconds        = 0;
    std::vector<float>  shapes;       // [output DoF][surface mode], single precision: the
                                      // surface update streams them, and sums them in single
                                      // precision where the CPU has AVX2 (surface_product.h;
                                      // relative to the sum of the terms' magnitudes, rounding
                                      // 6e-8 stored, about (M / 8 + 5) 6e-8 summed)
    std::vector<double> input_shapes; // [input DoF][mode], every mode: displacement there
    // [input DoF][mode]: the modal force of a unit force there, when it differs from
    // input_shapes (ModalData::load_shapes); empty: input_shapes.
    std::vector<double> input_load_shapes;
    std::vector<double> step;         // [mode][3 x 5], as ModalData::step
    std::vector<double> w2;           // (rad/s)^2 per mode
    std::vector<double> h0_inputs;    // the force loop's feed-through to the output of input
                                      // DoF i from input DoF k, [i][k]: H[0] (with K < N
                                      // modes, plus the dropped modes' static correction)
    std::vector<float>  residual;     // static correction E, [input DoF][output DoF]
    std::vector<double> centrifugal_load; // [mode][3][3], as ModalData's; empty: none
    unsigned            inertial_modes = 0;  // as ModalData's
    std::vector<double> inertial_coupling;   // [3][3][mode][mode], as ModalData's; empty: none
    /// Bytes in memory.
    double
    bytes() const
    {
      return 8.0 * (input_shapes.size() + input_load_shapes.size() + step.size() +
                    h0_inputs.size() + centrifugal_load.size() +
                    inertial_coupling.size()) +
             4.0 * (shapes.size() + residual.size());
    }
  };

  /// Throws InputError if the model file carried no modal realization or asks for more modes
  /// than it has.
  ModalModel
  make_modal_model(const ImpulseResponseModel &model, const ModalModelOptions &options);

  /// The public SurfaceState (irdm/irdm.h): what the full surface update needs of a modal
  /// runtime's state after a step (the M surface modes' displacements, the step's forces for
  /// the static correction, and a free body's pose).
  using ModalSurfaceState = SurfaceState;

  ModalSurfaceState
  make_surface_state(const ModalModel &model);

  /// The full surface update from a saved state: displacement of every output DoF (m).
  /// Allocates nothing.
  void
  surface_displacement(const ModalModel &model, const ModalSurfaceState &state, double *u);

  /// Reads the surface shapes once (a load per cache line), so that the next
  /// surface_displacement finds them in this core's cache. A deformation thread that sleeps
  /// between frames finds them evicted (about 50 us for the cat's 1554 x 100 floats from
  /// memory against 10 warm, reports/play); called shortly before a frame, off the path from
  /// the newest force state to the surface, it takes that load out of the update's latency.
  /// Allocates nothing; never on the haptic thread (it streams the whole of Phi_M).
  void
  warm_surface(const ModalModel &model);

  /// Part `part` (0 to parts - 1) of warm_surface: the shapes in `parts` contiguous pieces,
  /// so that a thread that keeps them warm while it waits can read its clock between pieces.
  void
  warm_surface(const ModalModel &model, size_t part, size_t parts);

  /// A known force on an input vertex during one step (N, model frame): a probe's or a
  /// device's, given rather than solved for (AppliedForce's, in the model's input numbering).
  struct InputForce
  {
    unsigned              input_vertex = 0;
    std::array<double, 3> force{};
  };

  /// Point interaction run from a modal model; same interface and guarantees as
  /// PointInteraction (step() and surface_displacement() allocate nothing).
  class ModalInteraction : public ProbeOutputs
  {
  public:
    explicit ModalInteraction(const ModalModel &model, const VertexContactOptions &planes = {});
    bool
    can_touch(int triangle) const;
    bool
    can_touch(const ProbeTarget &probe) const;
    bool
    step(const ProbeTarget *probes, int n_probes);
    /// Many-vertex plane contact, as PointInteraction::step(const PlaneTarget *, int).
    bool
    step(const PlaneTarget *planes, int n_planes);
    /// The same for the deformation of a free body (irdm/free_body.h): planes in the model
    /// frame where the body's rigid motion without contact takes them, and the rigid body's
    /// own compliance over the step added to the feed-through, so that the contact meets the
    /// rigid motion the forces will cause as well as the deformation.
    bool
    step(const PlaneTarget *planes, int n_planes, const RigidStepCompliance &rigid);
    /// The same with known forces on input vertices this step (probes on a free body): they
    /// join the force history, and the contact solve sees what they do within the step
    /// (their feed-through, rigid compliance included). Returns false if a vertex is out of
    /// range.
    bool
    step(const PlaneTarget *planes, int n_planes, const RigidStepCompliance &rigid,
         const InputForce *applied, int n_applied);
    /// This step's forces: the input DoFs pushed and the force on one (N, model frame).
    const std::vector<unsigned> &
    pushed_inputs() const
    {
      return pushed_;
    }
    double
    force_on_input(unsigned k) const
    {
      return force_now_[k];
    }
    /// Displacement of input DoF k after the latest step (m), from the force loop's modes (every
    /// mode unless force_modes was set). O(modes).
    double
    input_displacement(unsigned k) const;
    /// Displacement of input DoF k at the start of the latest step where the free body's
    /// contact took it as a lever (a candidate of that step), else after the step: where the
    /// contact solve put its lever, so that the torque acts where the solve expected it.
    double
    lever_displacement(unsigned k) const
    {
      return lever_set_[k / 3] ? lever_u_[k] : input_displacement(k);
    }
    /// A free body's spin (rad/s, model frame) from the next step on: its centrifugal force
    /// -M (omega x (omega x r)) about the centre of mass loads the force loop's modes, in the
    /// history the contact solve sees as well (ModalModel::centrifugal_load; the modes beyond
    /// K and the surface's static correction leave it out). Stays until set again; zero turns
    /// it off. Returns false (and changes nothing) if the model has no centrifugal load or
    /// omega is not finite. Allocates nothing.
    bool
    set_spin(const Eigen::Vector3d &omega);
    /// Which of the moving frame's forces on the deformation the next steps take (a free
    /// body's; docs/free-body.md), on the first min(inertial modes, force-loop modes) modes
    /// (ModalModel::inertial_coupling): the Euler force -sum_a alpha_a G_a q, the spin
    /// softening -(sum_ab omega_a omega_b J_ab - |omega|^2 I) q and the Coriolis force
    /// -2 sum_a omega_a G_a q'. Each step evaluates them at the state the step reaches without
    /// its own force (q, q' at the step's end but for this step's contact) with the frame's
    /// motion of set_frame_motion, and takes them as a known load of the step, in the history
    /// the contact solve reads. Returns false (and changes nothing) if a term is asked of a
    /// model without the couplings.
    /// `modes`: on the lowest that many of them only (0: every one the model holds).
    bool
    set_frame_forces(bool euler, bool spin_softening, bool coriolis, unsigned modes = 0);
    /// Before the first step: the spin's centrifugal load (set_spin's) acts from t = 0, as the
    /// FEM's balance at t = 0 has it (a body that starts spinning is loaded at once): the
    /// state's acceleration and the previous step's force take it. Without it the first step
    /// would ramp the load in over the step, half a step late. Returns false (and changes
    /// nothing) after a step.
    bool
    load_from_start();
    /// The frame's angular velocity and acceleration at the next step's end (rad/s, rad/s^2,
    /// model frame). Returns false (and changes nothing) if either is not finite.
    bool
    set_frame_motion(const Eigen::Vector3d &omega, const Eigen::Vector3d &alpha);
    /// A free body's inertia tensor less the undeformed one (kg m^2, model frame, about the
    /// centre of mass), to first order in the deformation of the force loop's modes:
    ///   dI = sum_i u_i (2 tr(C_i) I - C_i - C_i^T),  C_i[a][b] = phi_i^T M w_ab, w_ab the field
    ///   e_a (x_b - c_b) (c the centre of mass)
    /// (ModalModel::centrifugal_load). Its gradient in u_i is what makes the centrifugal load
    /// sum_ab S_ab C_i[a][b] = 1/2 omega^T (dI/du_i) omega the force of the spin's kinetic
    /// energy 1/2 L^T I^-1 L at fixed angular momentum: the two together exchange energy
    /// between spin and stretch and create none. Zero for a model without the load.
    /// O(9 modes); allocates nothing.
    Eigen::Matrix3d
    inertia_change() const;
    /// A free body's angular momentum and inertia to second order in the deformation (kg m^2/s,
    /// kg m^2; model frame, about the centre of mass; docs/free-body.md), at the state of the
    /// last step, on the first modes of set_frame_forces (those the model holds couplings for):
    ///   h  = sum_ij M_ij u_i x u'_j,                 h_a = q'^T G_a q,
    ///   I2 = sum_ij M_ij (u_i . u_j I - u_i u_j^T), (I2)_ab = delta_ab sum_c q^T J_cc q - q^T J_ab q.
    /// h is the deformation's own angular momentum (the Coriolis force's reaction on the rigid
    /// body): the body's is R (I(q) omega + h). All zero for a model without the couplings.
    /// 9 R^2 multiply-adds; allocates nothing.
    void
    second_order_momentum(Eigen::Vector3d &h, Eigen::Matrix3d &I2) const;
    /// Energy of the modes in the force loop, 1/2 sum (v_i^2 + w_i^2 u_i^2) (J; M-orthonormal
    /// shapes): kinetic plus strain energy of the deformation.
    double
    elastic_energy() const;
    const VertexContact &
    vertex_contact() const
    {
      return vertex_contact_;
    }
    void
    surface_displacement(double *u) const;
    /// A bound on the length of every input vertex's displacement after the latest step (m):
    /// sqrt(2 x strain energy) of the force-loop modes times the largest vertex flexibility
    /// sqrt(sum_i |phi_i(v)|^2 / w_i^2). The plane contact takes the vertices within its
    /// margin of a plane as deformed (vertex_contact.h); this bounds which ones it has to look
    /// at. Infinite for a model without a positive w_i^2 for every force-loop mode. O(modes).
    double
    deformation_reach() const;
    /// Reads what the next step reads if it touches the inputs the last step touched (the step
    /// matrices, the state, those inputs' shapes and feed-through), so that it finds them in
    /// this core's cache. For a force thread that waits for its tick: called at the start of
    /// the wait, it takes the cache misses out of the step's latency. Changes nothing.
    void
    warm_step() const;
    /// Copies what surface_displacement needs into state (made by make_surface_state for
    /// this model). Allocates nothing.
    void
    save_surface_state(ModalSurfaceState &state) const;

  private:
    const ModalModel      &model_;
    unsigned               N_, M_; // force-loop modes (K), surface modes
    size_t                 stride_; // modes per row of input_shapes (all of the model's)
    std::vector<double>    coef_;          // step matrices, [entry of 3 x 5][mode]
    std::vector<double>    xu_, xv_, xa_;  // [mode] state (u, v, a) after the last step
    std::vector<double>    fu_, fv_, fa_;  // [mode] this step's state without its force
    std::vector<double>    g_prev_;  // [mode] modal force of the last step
    std::vector<double>    spin_load_; // [mode] the spin's centrifugal load (set_spin)
    bool                   spinning_ = false;
    // The frame forces (set_frame_forces): on the first R_ modes, this step's load [mode],
    // scratch [mode], and the frame's motion.
    unsigned               R_ = 0;
    bool                   euler_ = false, spin_softening_ = false, coriolis_ = false;
    std::vector<double>    frame_load_, frame_scratch_;
    mutable std::vector<double> momentum_scratch_; // [mode] (second_order_momentum)
    Eigen::Vector3d        omega_ = Eigen::Vector3d::Zero(), alpha_ = Eigen::Vector3d::Zero();
    bool
    frame_forces_on() const
    {
      return euler_ || spin_softening_ || coriolis_;
    }
    void
    add_frame_load();
    // J_ab = Phi_a^T M_s Phi_b on the first R_ modes (ModalModel::inertial_coupling).
    using CouplingBlock =
      Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>, 0,
                 Eigen::OuterStride<>>;
    CouplingBlock
    coupling_block(int a, int b) const;
    std::vector<double>    force_now_;  // [input DoF] this step's force
    std::vector<unsigned>  pushed_;     // inputs with force this step
    std::vector<char>      is_pushed_;
    VertexContact          vertex_contact_;
    // Per plane-contact slot, the row n^T Phi_v (N modes) of its candidate: the history along
    // the normal is then one dot product with fu_ (VertexContact::step's slots).
    std::vector<double>    projected_;
    const RigidStepCompliance *rigid_ = nullptr; // during a free body's step
    // [input DoF] a free-body contact candidate's displacement at the step's start (its
    // lever), for the input vertices listed in lever_vertices_ (lever_set_ marks them).
    std::vector<double>        lever_u_;
    std::vector<char>          lever_set_;
    std::vector<unsigned>      lever_vertices_;
    // The plane contact's deformed candidate test: a vertex's displacement is estimated from
    // this many of the first modes (the slow ones, which move the surface most), the rest
    // bounded. [input vertex] sqrt(sum_i |phi_i(v)|^2 / w_i^2) over the force-loop modes and
    // over those past the first reach_modes_ (m per sqrt(J)).
    static constexpr unsigned reach_modes = 32;
    unsigned                  reach_modes_ = 0;
    std::vector<double>       flexibility_all_, flexibility_tail_;
    // The input shapes of the force-loop modes in single precision, per input vertex its
    // first reach_modes_ (x, y, z) and then the rest (x, y, z): the test's two stages.
    std::vector<float>        test_shapes_;
    std::vector<float>        xu_test_;     // [force-loop mode] xu_ in single precision
    double                    largest_flexibility_ = 0;
    bool                      bounded_ = false; // every force-loop mode has w_i^2 > 0
    // sum_{first <= i < end} w_i^2 u_i^2 over force-loop modes (J; its root the strain norm).
    double
    strain_sum(unsigned first, unsigned end) const;
    // deformation_reach for a strain norm sqrt(strain_sum(0, N_)) already taken.
    double
    reach_of(double strain_all) const;
    const InputForce        *applied_ = nullptr; // during a step with known forces
    int                        n_applied_ = 0;

    // The two halves of a step around its contact solve: the state with no force this step,
    // then this step's force into the state.
    void
    begin_step();
    void
    end_step();
    // History at the output of input DoF i, H[0] from input DoF k to output DoF j, and a force
    // on input DoF k into this step's sample (probe_step.h, vertex_contact_step.h).
    double
    history_row(unsigned i) const;
    double
    history_along(unsigned in_vertex, const std::array<double, 3> &normal, int slot, bool fresh);
    double
    feed_through(unsigned k, unsigned j) const;
    // The same without a free body's rigid compliance (the contact adds it in rank-6 form).
    double
    deformation_feed_through(unsigned k, unsigned j) const;
    void
    push(unsigned k, double f);
  };
} // namespace irdm
