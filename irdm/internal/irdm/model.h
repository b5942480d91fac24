#pragma once
// An impulse-response model as written by 'irdm precompute' (docs/model-format.md).
// Units SI; H in m/N. Convention: u[n] = sum_s H[s] f[n - s], f[n] the force held during step
// n (impulse = f * time_step), H[0] the direct feed-through.
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace irdm
{
  /// What every model kind shares: time step, length, DoFs and the surface geometry (read from
  /// the same HDF5 groups by every loader).
  struct ModelFrame
  {
    double   time_step = 0; // s
    unsigned length    = 0; // T, samples per response
    unsigned n_inputs  = 0; // input DoFs (3 per input vertex)
    unsigned n_outputs = 0; // output DoFs (3 per output vertex)

    std::vector<long long>             output_node_tags;
    std::vector<std::array<double, 3>> output_coordinates; // m, undeformed
    std::vector<long long>             input_node_tags;
    std::vector<unsigned>              input_output_index; // output vertex of each input vertex
    std::vector<int>                   output_input_index; // input vertex, or -1
    std::vector<std::array<unsigned, 3>> triangles;        // output vertex indices, outward
    std::vector<int>                     triangle_surface; // index into surface_names
    std::vector<std::string>             surface_names;

    std::string integrator, mesh_hash, storage_on_disk;

    // A free body (no fixed surface; format version 2, root attribute body = "free"): its
    // responses hold the deformation only, the six rigid-body modes removed, and the runtime
    // moves it by rigid-body dynamics with these mass properties (irdm/rigid_body.h).
    bool                                 free_body = false;
    double                               mass      = 0;   // kg
    std::array<double, 3>                center_of_mass{}; // m, model frame
    std::array<std::array<double, 3>, 3> inertia{};        // kg m^2, about the centre of mass
  };

  /// The modal realization the precompute stores with H (/modes): every mode of the fixed
  /// body, M-orthonormal shapes at the outputs, and each mode's integrator step
  /// x_{n+1} = A x_n + b_new g_{n+1} + b_old g_n, x = (u, v, a), g the modal force.
  struct ModalData
  {
    unsigned            n_modes = 0;   // 0: the file holds no realization
    std::vector<double> frequency_hz;  // ascending
    std::vector<double> damping_ratio;
    std::vector<double> shapes;        // [output DoF][mode]: the response (displacement) shapes
    // [output DoF][mode]: the shapes a force at an output drives, when they differ from
    // `shapes` (a free body's rigid-fit route: H[s] = shapes diag(q[s]) load_shapes^T is not
    // symmetric). Empty: the same as `shapes`.
    std::vector<double> load_shapes;
    std::vector<double> step;          // [mode][3 x 5]: [A | b_new | b_old], row-major
    // A free body's dense-route model: [mode][a][b] = phi_i^T M w_ab, w_ab the field
    // e_a (x_b - c_b) about the centre of mass c (the modal load of the spin's centrifugal
    // force; docs/model-format.md). Empty: the file has none.
    std::vector<double> centrifugal_load;
    // A free body's dense-route model: the mass couplings of the first inertial_modes modes'
    // components, [a][b][i][j] = phi_i,a^T M_s phi_j,b (M = M_s (x) I_3; docs/free-body.md),
    // for the frame's Euler, spin-softening and Coriolis forces. Empty: the file has none.
    unsigned            inertial_modes = 0;
    std::vector<double> inertial_coupling;
  };

  /// The uncompressed model: H in full, or only its modal realization (modal_only).
  struct ImpulseResponseModel : ModelFrame
  {
    ModalData modes;
    // Format version 3 (precompute --modal-only): /modes without H, h_double and h_float
    // empty; only make_modal_model reads such a model (from the modes alone).
    bool modal_only = false;

    bool        double_storage = true; // which of h_double / h_float holds H
    std::vector<double> h_double;      // [input DoF][s][output DoF]
    std::vector<float>  h_float;

    double
    h(unsigned input_dof, unsigned s, unsigned output_dof) const
    {
      const size_t i = (static_cast<size_t>(input_dof) * length + s) * n_outputs + output_dof;
      return double_storage ? h_double[i] : static_cast<double>(h_float[i]);
    }
    /// Bytes of H in memory.
    double
    bytes() const
    {
      return double_storage ? 8.0 * h_double.size() : 4.0 * h_float.size();
    }
    /// A copy with H rounded to float (to measure what float storage costs).
    ImpulseResponseModel
    as_float() const;
  };

  /// What a use of a model needs: H itself (the direct convolution, compression, comparisons),
  /// or its modal realization, which a file written with --modal-only holds alone.
  enum class ModelParts
  {
    impulse_response,
    modal_realization
  };

  /// Loads and checks a model file. InputError for: a missing or non-HDF5 file, an unknown
  /// format or version, missing datasets, inconsistent shapes, NaN or Inf in H, a time step
  /// different from expected_time_step (relative 1e-12) when one is given, and a file without
  /// H (format version 3) when `parts` asks for H. A file with H is read whole either way.
  ImpulseResponseModel
  load_model(const std::string &path, std::optional<double> expected_time_step = {},
             ModelParts parts = ModelParts::impulse_response);

} // namespace irdm
