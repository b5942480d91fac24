// Impulse-response precompute by exact modal decoupling of the FEM's time integrator.
// Plain C++ with LAPACK/BLAS, HDF5 and MPI; the FEM is used through its public interface.
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <irdm_common/format.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/mesh.h>

#include "blas.h"
#include "integrator.h"
#include "model_regions.h"
#include "mpi_rank.h"
#include "frame_couplings.h"
#include "provenance.h"

#include <Eigen/Dense>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <map>
#include <set>
#include <memory>
#include <numeric>
#include <sstream>
#include <thread>
#include <type_traits>

namespace irdm::fem
{
  namespace
  {
    using Clock = std::chrono::steady_clock;
    // The dense route holds K, M and the eigenvectors as dense n x n matrices (3 n^2 doubles:
    // 3.5 GB at 12000); beyond this the sparse route is taken.
    constexpr unsigned dense_route_limit = 12000;
    // Modes the sparse route keeps when --modes is not given (measured: reports/scaling/).
    constexpr unsigned default_sparse_modes = 200;
    double
    since(const Clock::time_point t0)
    {
      return std::chrono::duration<double>(Clock::now() - t0).count();
    }

    // Row-major C (m x n, row stride ldc) = A (m x k) * B^T, B (n x k) row-major:
    // column-major C^T = B A^T.
    void
    gemm_abt(int m, int n, int k, const float *A, int lda, const float *B, int ldb, float *C,
             int ldc)
    {
      const float one = 1, zero = 0;
      sgemm_("T", "N", &n, &m, &k, &one, B, &ldb, A, &lda, &zero, C, &ldc);
    }
    void
    gemm_abt(int m, int n, int k, const double *A, int lda, const double *B, int ldb, double *C,
             int ldc)
    {
      const double one = 1, zero = 0;
      dgemm_("T", "N", &n, &m, &k, &one, B, &ldb, A, &lda, &zero, C, &ldc);
    }

    // Which modes a step's sum needs. Damping and the integrator's own dissipation
    // (generalized-alpha with rho_inf < 1 takes a mode far above 1 / tau down by about rho_inf
    // per step) make most modes' responses vanish within tens of steps, while the lowest ring
    // for the whole length: at step s the sum H[s] = sum_i h_i[s] phi_out_i phi_in_i^T needs
    // only the modes still alive. Mode i is kept up to its last step l_i with
    // |h_i[s]| max_k |phi_in[k][i]| max_j |phi_out[j][i]| > eps D / nm, where D is the largest
    // driving-point response of an input (max over s and k of |sum_i h_i[s] phi_in[k][i]^2|).
    // What is left out of any entry at any step is then at most eps D. eps is a tenth of the
    // storage's unit round-off, so every entry moves by less than the rounding of the largest.
    struct LiveModes
    {
      std::vector<unsigned> order;  // modes by l_i, longest-lived first (stable: by index)
      std::vector<unsigned> alive;  // alive[s]: modes with l_i >= s, a prefix of `order`
      std::vector<unsigned> block;  // step blocks [block[b], block[b + 1]) of one GEMM width
      std::vector<unsigned> width;  // width[b] = alive[block[b]]: the block's modes
      double                work = 1; // sum over steps of width, over T * nm: the GEMM left
      double                tolerance = 0; // eps D: the most left out of any entry (m/N)
    };

    LiveModes
    live_modes(const std::vector<double> &h, const std::vector<double> &phi_in,
               const std::vector<double> &phi_out, const unsigned T, const unsigned nm,
               const double eps)
    {
      const size_t nin = phi_in.size() / nm, nout = phi_out.size() / nm;
      // D: the driving-point responses of every input at every step, one GEMM.
      std::vector<double> p2(phi_in.size()), drive(nin * T);
      for (size_t x = 0; x < phi_in.size(); ++x)
        p2[x] = phi_in[x] * phi_in[x];
      gemm_abt(static_cast<int>(nin), static_cast<int>(T), static_cast<int>(nm), p2.data(),
               static_cast<int>(nm), h.data(), static_cast<int>(nm), drive.data(),
               static_cast<int>(T));
      double D = 0;
      for (const double d : drive)
        D = std::max(D, std::abs(d));
      std::vector<double> reach(nm, 0.0); // max_k |phi_in[k][i]| max_j |phi_out[j][i]|
      {
        std::vector<double> in_max(nm, 0.0), out_max(nm, 0.0);
        for (size_t k = 0; k < nin; ++k)
          for (unsigned i = 0; i < nm; ++i)
            in_max[i] = std::max(in_max[i], std::abs(phi_in[k * nm + i]));
        for (size_t j = 0; j < nout; ++j)
          for (unsigned i = 0; i < nm; ++i)
            out_max[i] = std::max(out_max[i], std::abs(phi_out[j * nm + i]));
        for (unsigned i = 0; i < nm; ++i)
          reach[i] = in_max[i] * out_max[i];
      }
      const double threshold = eps * D / nm;
      std::vector<long> last(nm, -1);
      LiveModes lm;
      lm.tolerance = eps * D;
      for (unsigned i = 0; i < nm; ++i)
        for (long s = static_cast<long>(T) - 1; s >= 0; --s)
          if (std::abs(h[static_cast<size_t>(s) * nm + i]) * reach[i] > threshold)
            {
              last[i] = s;
              break;
            }
      lm.order.resize(nm);
      std::iota(lm.order.begin(), lm.order.end(), 0u);
      std::stable_sort(lm.order.begin(), lm.order.end(),
                       [&](unsigned a, unsigned b) { return last[a] > last[b]; });
      lm.alive.assign(T, 0);
      for (unsigned i = 0; i < nm; ++i)
        for (long s = 0; s <= last[i]; ++s)
          ++lm.alive[static_cast<size_t>(s)];
      // Blocks: a GEMM per block and input, so not too short (8 steps at least) and not much
      // wider than the steps in it need (a new block once alive falls below 90 % of its width).
      double work = 0;
      for (unsigned s0 = 0; s0 < T;)
        {
          unsigned s1 = s0 + 1;
          while (s1 < T && (s1 - s0 < 8 || lm.alive[s1] >= 0.9 * lm.alive[s0]))
            ++s1;
          lm.block.push_back(s0);
          lm.width.push_back(lm.alive[s0]);
          work += static_cast<double>(s1 - s0) * lm.alive[s0];
          s0 = s1;
        }
      lm.block.push_back(T);
      lm.work = work / (static_cast<double>(T) * nm);
      return lm;
    }

    // One step of one mode (unit mass, stiffness w2, damping alpha + beta w2) of the FEM's
    // recursion: state (u, v, a) at step n and the modal forces f_old (step n) and f_new
    // (step n + 1) give the state at n + 1. The algebra is term by term that of
    // ElasticDynamics::Impl::run().
    struct ModalStep
    {
      double dt, c_m, c_c, m_v, m_a, c_v, c_a, k_eff, w2, alpha, beta_r;
      IntegratorCoefficients c;
      ModalStep(const Scene &sc, const IntegratorCoefficients &coef, const double w2_)
        : dt(sc.time_step)
        , w2(w2_)
        , alpha(sc.rayleigh_alpha)
        , beta_r(sc.rayleigh_beta)
        , c(coef)
      {
        const StepCoefficients k(c, dt);
        c_m = k.c_m, c_c = k.c_c, m_v = k.m_v, m_a = k.m_a, c_v = k.c_v, c_a = k.c_a;
        const EffectiveStiffness e(c, k, alpha, beta_r);
        k_eff = e.stiffness * w2 + e.mass;
      }
      void
      operator()(double &u, double &v, double &a, const double f_old, const double f_new) const
      {
        const double m_part = c_m * u + m_v * v + m_a * a;
        const double c_part = c_c * u + c_v * v + c_a * a;
        const double rhs    = (1 - c.alpha_f) * f_new + c.alpha_f * f_old +
                           (m_part + alpha * c_part) + w2 * (beta_r * c_part - c.alpha_f * u);
        const double u_new = rhs / k_eff;
        const double a_new = (u_new - u - dt * v) / (c.beta * dt * dt) - (1 / (2 * c.beta) - 1) * a;
        v += dt * (1 - c.gamma) * a + dt * c.gamma * a_new;
        u = u_new;
        a = a_new;
      }
      // The step as a matrix: x_{n+1} = A x_n + b_new f_{n+1} + b_old f_n, x = (u, v, a);
      // row-major 3 x 5: [A | b_new | b_old]. Exact, since the step is linear.
      std::array<double, 15>
      matrix() const
      {
        std::array<double, 15> m{};
        for (int col = 0; col < 5; ++col)
          {
            double x[3] = {col == 0 ? 1.0 : 0.0, col == 1 ? 1.0 : 0.0, col == 2 ? 1.0 : 0.0};
            (*this)(x[0], x[1], x[2], col == 4 ? 1.0 : 0.0, col == 3 ? 1.0 : 0.0);
            for (int row = 0; row < 3; ++row)
              m[5 * row + col] = x[row];
          }
        return m;
      }
    };

    // Response of one mode to a unit modal force held during step 0: q[s] for s < T, and the
    // energy after step 1 (when the impulse is fully delivered) and after step T.
    void
    modal_response(const Scene &sc, const IntegratorCoefficients &c, const double w2, double *q,
                   const unsigned T, double &energy0, double &energyT)
    {
      const ModalStep step(sc, c, w2);
      double          u = 0, v = 0, a = 0, f = 0;
      for (unsigned s = 0; s <= T; ++s)
        {
          const double f_new = s == 0 ? 1.0 : 0.0;
          step(u, v, a, f, f_new);
          f = f_new;
          if (s < T)
            q[s] = u;
          const double e = 0.5 * (v * v + w2 * u * u);
          if (s == 1) // the impulse is fully delivered (generalized-alpha spreads it over 2 steps)
            energy0 = e;
          if (s == T)
            energyT = e;
        }
    }

    std::string
    join(const std::vector<std::string> &v)
    {
      std::string s;
      for (const auto &x : v)
        s += (s.empty() ? "" : ",") + x;
      return s;
    }

    // Route 1 of a free body (FreeBodyRoute::rigid_fit): takes out of every column of phi
    // (row-major, 3 rows per vertex at x, nm columns) its best rigid field t + theta x (x - c)
    // by least squares with weight w[v] per vertex, and returns |removed| / |phi_i| per column.
    // The linear FEM's rigid motions are exactly these six fields (infinitesimal rotations), so
    // this is the best rigid fit of a response sample, and being linear it acts on each mode's
    // shape alone: a recorded sum_i phi_i q_i[s] minus its fit is sum_i (phi_i - R c_i) q_i[s].
    std::vector<double>
    remove_rigid_fit(std::vector<double> &phi, const unsigned nm,
                     const std::vector<std::array<double, 3>> &x, const std::vector<double> &w)
    {
      using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      const size_t    nv = x.size();
      Eigen::Vector3d c  = Eigen::Vector3d::Zero(); // weighted centroid: R^T W R well scaled
      double          wsum = 0;
      for (size_t v = 0; v < nv; ++v)
        {
          c += w[v] * Eigen::Vector3d(x[v][0], x[v][1], x[v][2]);
          wsum += w[v];
        }
      c /= wsum;
      Eigen::MatrixXd R(3 * nv, 6), WR(3 * nv, 6);
      for (size_t v = 0; v < nv; ++v)
        {
          const Eigen::Vector3d r = Eigen::Vector3d(x[v][0], x[v][1], x[v][2]) - c;
          Eigen::Matrix3d       r_cross;
          r_cross << 0, -r(2), r(1), r(2), 0, -r(0), -r(1), r(0), 0;
          R.block<3, 3>(3 * v, 0) = Eigen::Matrix3d::Identity();
          R.block<3, 3>(3 * v, 3) = -r_cross; // theta x r = -r x theta
          WR.middleRows<3>(3 * v) = w[v] * R.middleRows<3>(3 * v);
        }
      Eigen::Map<RowMajor>  P(phi.data(), static_cast<Eigen::Index>(3 * nv), nm);
      const Eigen::MatrixXd C       = (R.transpose() * WR).ldlt().solve(WR.transpose() * P);
      const Eigen::MatrixXd removed = R * C;
      std::vector<double>   share(nm);
      for (unsigned i = 0; i < nm; ++i)
        share[i] = removed.col(i).norm() / P.col(i).norm();
      P -= removed;
      return share;
    }
    /// The precompute of one scene's impulse responses, shaped as a deal.II tutorial program:
    /// setup (the FEM, the route and the vertex sets), the modes (dense or sparse route, the
    /// free body's rigid modes removed), the modal responses, the output file (a part file
    /// whose spec fits is resumed), the responses in chunks, run. Collective over
    /// MPI_COMM_WORLD; rank 0 computes the modes and writes the file.
    class ImpulseResponsePrecompute
    {
    public:
      ImpulseResponsePrecompute(const Scene &scene, const PrecomputeOptions &options);
      PrecomputeReport
      run();

    private:
      void
      setup();
      void
      compute_modes();
      void
      sparse_modes();
      void
      dense_modes();
      void
      centrifugal_loads(const DenseSystem &sys, const std::vector<double> &phi);
      void
      inertial_couplings(const DenseSystem &sys, const std::vector<double> &phi);
      void
      fit_route1(const DenseSystem &sys);
      void
      modal_responses();
      void
      open_output();
      std::string
      spec_id_of() const;
      void
      write_metadata(h5::Writer &f, const std::string &spec_id);
      void
      write_geometry_and_modes(h5::Writer &f);
      void
      write_responses();
      template <class Scalar>
      void
      compute_chunk(unsigned c, const std::vector<Scalar> &phi_out_s, Scalar *result) const;
      template <class Scalar>
      double
      run_chunks();
      template <class Scalar>
      void
      fill_by_reciprocity(unsigned c, Scalar *data,
                          std::vector<std::vector<std::vector<Scalar>>> &block) const;

      const Scene                                    &scene;
      const PrecomputeOptions                        &options;
      const Clock::time_point                         t_start = Clock::now();
      const MpiRank                                   mpi;
      const int                                       rank, size;
      const std::function<void(const std::string &)> log;
      const IntegratorCoefficients                    coef;
      OutputLock                                      output_lock; // rank 0: the output's
      PrecomputeReport                                rep;

      // The body and the route. A scene that fixes no surface is a free body: its six
      // rigid-body modes (w = 0) are separated from the elastic ones and left to the runtime's
      // rigid-body dynamics.
      bool        free_body = false, rigid_fit = false, sparse = false;
      unsigned    n_rigid = 0;  // the free body's rigid-body modes, not kept
      unsigned    T = 0, n = 0; // samples per response; free DoFs
      unsigned    n_lowest = 0; // exact eigenmodes kept (all of them on the dense route)
      const char *weights_name = "uniform"; // route 1's fit weights
      std::unique_ptr<ElasticDynamics> fem;
      SurfaceMesh                      boundary;
      // The vertex sets (boundary indices), each input's row among the outputs, and the free
      // DoF of each output and input DoF (3 * vertex + axis).
      std::vector<unsigned> out_v, in_v, in_as_out;
      std::vector<int>      out_free, in_free;
      unsigned              nin = 0, nout = 0;

      // The modes, M-orthonormal, at the output and input DoFs (row-major, rows x nm).
      unsigned            nm           = 0; // modes kept
      double              rigid_w2_max = 0; // free body: largest |w^2| of the rigid modes
      std::vector<double> w2, phi_out, phi_in;
      std::vector<double> compliance; // sparse route: the static compliance, nout x nin
      std::vector<double> load_out;   // route 1: the modes' shapes at the outputs before the fit
      // Free body (either route): each elastic mode's load of the spin's centrifugal field,
      // [mode][a][b] = phi_i^T M w_ab, w_ab the field e_a (x_b - c_b) (x - c from the centre of
      // mass): the modal force of -M (omega x (omega x r)) is sum_ab S_ab [i][a][b] with
      // S = |omega|^2 I - omega omega^T (docs/model-format.md).
      std::vector<double> centrifugal;
      // Free body (either route): the mass couplings of the first n_inertial elastic modes'
      // components, [a][b][i][j] = Phi_a(i)^T M_s Phi_b(j) (M = M_s (x) I_3), from which the
      // runtime forms the frame's Euler, spin-softening and Coriolis forces on the
      // deformation (docs/free-body.md).
      unsigned            n_inertial = 0;
      std::vector<double> inertial;

      // The modal responses h[s][i] and the modes alive at each step; h and Phi_in with their
      // modes in live order, so that a row of a chunk's GEMM operand is a contiguous product.
      std::vector<double> h, h_live, phi_in_live;
      LiveModes           live;

      // The file: H in chunks of inputs, each marked done when written.
      size_t                      per_input = 0, scalar = 0; // H values per input; bytes each
      unsigned                    chunk = 0, n_chunks = 0, workers = 1;
      bool                        symmetric = false; // H[s] symmetric: reciprocity halves the work
      std::vector<long long>      done;
      std::unique_ptr<h5::Writer> w;
      double                      write_seconds = 0;
    };
  } // namespace

  std::vector<unsigned>
  select_vertices(const std::optional<VertexRegion> &region, const SurfaceMesh &b,
                  const std::vector<int> &vertex_dof_to_free, const std::string &what)
  {
    std::vector<char> in_surface(b.mesh_vertex.size(), 0);
    if (!region || region->surfaces.empty())
      std::fill(in_surface.begin(), in_surface.end(), 1);
    else
      for (const auto &name : region->surfaces)
        {
          bool found = false;
          for (unsigned t = 0; t < b.triangles.size(); ++t)
            if (b.triangle_surface[t] == name)
              {
                found = true;
                for (const unsigned v : b.triangles[t])
                  in_surface[v] = 1;
              }
          if (!found)
            throw InputError("model " + what + ": the mesh has no surface '" + name + "'");
        }
    std::vector<unsigned> out;
    for (unsigned i = 0; i < b.mesh_vertex.size(); ++i)
      {
        if (!in_surface[i] || vertex_dof_to_free[3 * b.mesh_vertex[i]] < 0)
          continue;
        if (region && !region->balls.empty())
          {
            bool inside = false;
            for (const auto &[center, radius] : region->balls)
              {
                double d2 = 0;
                for (int d = 0; d < 3; ++d)
                  d2 += std::pow(b.coordinates[i][d] - center[d], 2);
                inside = inside || d2 <= radius * radius;
              }
            if (!inside)
              continue;
          }
        out.push_back(i);
      }
    if (out.empty())
      throw InputError("model " + what + ": the region holds no free surface vertex");
    return out;
  }


  ImpulseResponsePrecompute::ImpulseResponsePrecompute(const Scene &scene, const PrecomputeOptions &options)
    : scene(scene)
    , options(options)
    , rank(mpi.rank)
    , size(mpi.size)
    , log(mpi.rank0(options.log))
    , coef(IntegratorCoefficients::from_scene(scene))
    , output_lock(lock_output_on_rank0(mpi, options.output, scene.mesh_file, "precompute"))
  {
    // A scene that fixes no surface is a free body: its six rigid-body modes (w = 0) are
    // separated from the elastic ones and left to the runtime's rigid-body dynamics.
    free_body    = scene.fixed_surfaces.empty();
    n_rigid      = free_body ? 6 : 0;
    rigid_fit    = free_body && options.free_route == FreeBodyRoute::rigid_fit;
    weights_name = options.fit_weights == RigidFitWeights::mass ? "mass" : "uniform";
    if (!free_body && options.free_route == FreeBodyRoute::rigid_fit)
      throw InputError("precompute: the rigid-fit route is for a free body (a scene with no "
                       "fixed surface); this scene fixes " + join(scene.fixed_surfaces));
    if (scene.gravity_enabled)
      log("note: gravity is a constant load and is not part of the impulse responses");

    rep.ranks          = size;
    rep.length         = options.length.value_or(scene.model.length);
    rep.double_storage = options.double_storage.value_or(scene.model.double_storage);
    T                  = rep.length;
  }

  void
  ImpulseResponsePrecompute::setup()
  {
    // 1. The FEM on the free DoFs, the route, and the vertex sets.
    const auto t0 = Clock::now();
    fem           = std::make_unique<ElasticDynamics>(scene);
    n             = fem->n_free_dofs();
    // The dense route keeps all modes (exact); beyond its limit, or when --modes is given, the
    // sparse route keeps the lowest ones plus a static correction for the rest.
    sparse = options.modes.has_value() || n > dense_route_limit;
    n_lowest =
      sparse ? options.modes.value_or(default_sparse_modes) : n - n_rigid;
    if (rigid_fit && sparse)
      throw InputError("precompute: the rigid-fit route (route 1) needs every elastic mode, on "
                       "the dense route (up to " + std::to_string(dense_route_limit) +
                       " free DoFs, without --modes); this body has " + std::to_string(n) +
                       ": use the modal route (route 2), which the sparse route supports");
    if (sparse && (n_lowest < 1 || n_lowest + n_rigid >= n))
      throw InputError("precompute: --modes " + std::to_string(n_lowest) + " must be between 1 and " +
                       std::to_string(n - 1 - n_rigid) + " (the body has " + std::to_string(n) +
                       " free DoFs; leave --modes out to keep all of them" +
                       (n > dense_route_limit ? ", which the dense route cannot here)" : ")"));
    if (!sparse)
      // Checked before the dense matrices are built (2 n^2 doubles: 6 GB at n = 19440).
      check_memory_estimate("the dense modal route (" + std::to_string(n) + " free DoFs)",
                            3.0 * n * n * 8, options.allow_large);
    const std::vector<int> dof_to_free = fem->vertex_dof_to_free();
    boundary                           = fem->boundary();
    out_v = select_vertices(scene.model.outputs, boundary, dof_to_free, "outputs");
    in_v = select_vertices(scene.model.inputs, boundary, dof_to_free, "inputs");
    if (options.input_stride > 1)
      {
        std::vector<unsigned> always;
        if (options.inputs_always)
          always = select_vertices(options.inputs_always, boundary, dof_to_free, "inputs (always)");
        std::vector<unsigned> sample;
        for (size_t i = 0; i < in_v.size(); ++i)
          if (i % options.input_stride == 0 ||
              std::binary_search(always.begin(), always.end(), in_v[i]))
            sample.push_back(in_v[i]);
        in_v = std::move(sample);
      }
    {
      for (const unsigned v : in_v)
        {
          const auto it = std::find(out_v.begin(), out_v.end(), v);
          if (it == out_v.end())
            throw InputError("model: every input vertex must also be an output (the contact "
                             "solve needs H_CC[0]); node " + std::to_string(boundary.node_tags[v]) +
                             " is not");
          in_as_out.push_back(static_cast<unsigned>(it - out_v.begin()));
        }
    }
    nin  = 3 * in_v.size();
    nout = 3 * out_v.size();
    // Free index of each output DoF (3 * vertex + axis) and each input DoF.
    const auto free_dofs_of = [&](const std::vector<unsigned> &verts) {
      std::vector<int> f(3 * verts.size());
      for (size_t k = 0; k < verts.size(); ++k)
        for (unsigned d = 0; d < 3; ++d)
          f[3 * k + d] = dof_to_free[3 * boundary.mesh_vertex[verts[k]] + d];
      return f;
    };
    out_free = free_dofs_of(out_v);
    in_free  = free_dofs_of(in_v);
    rep.n_free    = n;
    rep.sparse    = sparse;
    rep.n_inputs  = nin;
    rep.n_outputs = nout;
    rep.seconds_fem = since(t0);
    log("FEM: " + std::to_string(n) + " free DoFs; model " + std::to_string(nout) +
        " outputs x " + std::to_string(nin) + " inputs x " + std::to_string(T) + " samples (" +
        (rep.double_storage ? "double" : "float") + "); " +
        (sparse ? "sparse route, the lowest " + std::to_string(n_lowest) +
                    " modes + residual modes of the inputs"
                : std::string("dense route, all modes")) +
        (free_body ? "; free body: the 6 rigid-body modes are separated" : ""));
    if (const auto [allowed, machine] = cores_allowed_of_machine(); allowed < machine)
      log("note: this process may use " + std::to_string(allowed) + " of the machine's " +
          std::to_string(machine) + " cores (mpirun binds each rank to one core by default), " +
          "and the modes run on rank 0 alone while the other ranks wait: `mpirun --bind-to " +
          "none` lets its BLAS and MUMPS threads use every core (cat_fine P2, 2 ranks: 40.2 -> "
          "35.0 s)");
  }

  void
  ImpulseResponsePrecompute::compute_modes()
  {
    // 2. Modes, M-orthonormal, at the output and input DoFs (row-major, rows x nm), on rank 0
    //    and broadcast so that every rank uses the same bits. Dense route: all modes by LAPACK
    //    dsygvd. Sparse route: the lowest n_lowest by block Lanczos plus the residual modes of unit
    //    loads at the inputs, so that the basis holds K^-1 at the inputs exactly.
    const auto t0 = Clock::now();
    nm = sparse ? 0 : n - n_rigid;
    if (rank == 0)
      {
        if (sparse)
          sparse_modes();
        else
          dense_modes();
      }
    wait_for_all_quietly(); // the other ranks wait for rank 0's modes without taking a core
    MPI_Bcast(&nm, 1, MPI_UNSIGNED, 0, MPI_COMM_WORLD);
    w2.resize(nm);
    phi_out.resize(static_cast<size_t>(nout) * nm);
    phi_in.resize(static_cast<size_t>(nin) * nm);
    if (sparse)
      compliance.resize(static_cast<size_t>(nout) * nin);
    MPI_Bcast(w2.data(), nm, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Bcast(phi_out.data(), static_cast<int>(phi_out.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Bcast(phi_in.data(), static_cast<int>(phi_in.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (sparse)
      MPI_Bcast(compliance.data(), static_cast<int>(compliance.size()), MPI_DOUBLE, 0,
                MPI_COMM_WORLD);
    rep.n_modes    = nm;
    rep.free_body  = free_body;
    rep.rigid_fit  = rigid_fit;
    MPI_Bcast(&rigid_w2_max, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    rep.rigid_w2_max = rigid_w2_max;
    rep.n_lowest   = n_lowest;
    MPI_Bcast(&rep.rigid_fit_share_max, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Bcast(&rep.rigid_fit_share_mean, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (rigid_fit)
      log(std::string("route 1 (rigid fit, ") + weights_name + " weights over the " +
          std::to_string(nout / 3) + " outputs): the fit takes from a mode's output shape " +
          std::to_string(100 * rep.rigid_fit_share_mean) + " % on average, at most " +
          std::to_string(100 * rep.rigid_fit_share_max) + " %");
    rep.seconds_eigen = since(t0);
    if (w2[0] <= 0)
      throw std::runtime_error("the fixed system has a non-positive eigenvalue");
    rep.lowest_frequency_hz  = std::sqrt(w2[0]) / (2 * M_PI);
    rep.highest_frequency_hz = std::sqrt(w2[nm - 1]) / (2 * M_PI);
    rep.lowest_damping_ratio = 1e300;
    for (unsigned i = 0; i < nm; ++i)
      {
        const double w = std::sqrt(w2[i]);
        rep.lowest_damping_ratio =
          std::min(rep.lowest_damping_ratio, (scene.rayleigh_alpha + scene.rayleigh_beta * w2[i]) / (2 * w));
      }
    log("modes: " + fmt(rep.seconds_eigen, "%.1f") + " s; f = " +
        fmt(rep.lowest_frequency_hz, "%.4g") + " .. " + fmt(rep.highest_frequency_hz, "%.4g") +
        " Hz" +
        (sparse ? "; largest relative residual " + fmt(rep.eigen_residual, "%.2g") + ", " +
                    std::to_string(rep.eigen_iterations) + " block solves; of the time: " +
                    "factorization " + fmt(rep.seconds_factor, "%.1f") + " s, block " +
                    "Lanczos " + fmt(rep.seconds_lanczos, "%.1f") + " s (its solves " +
                    fmt(rep.seconds_solves, "%.1f") + " s), residual modes " +
                    "(factorization, solves, orthonormalization) " +
                    fmt(rep.seconds_static, "%.1f") + " s"
                : std::string()));
  }

  /// Sparse route (rank 0): the lowest n_lowest modes by block Lanczos plus the residual modes
  /// of unit loads at the inputs, so that the basis holds K^-1 at the inputs exactly.
  void
  ImpulseResponsePrecompute::sparse_modes()
  {
    // The shift of one step of the integrator: k_eff = a (w^2 + sigma) for every mode
    // (ModalStep), so residual modes from (K + sigma M)^-1 at the inputs make the
    // feed-through H[0] exact there, along with the static compliance. (Computing them
    // on rank 1 meanwhile was tried: on 2 cores the two factorizations slow each
    // other, cat_xfine P2 126 s on 2 ranks against 113-127 s on 1.)
    const IntegratorCoefficients ic = IntegratorCoefficients::from_scene(scene);
    const EffectiveStiffness     step(ic, StepCoefficients(ic, scene.time_step),
                                  scene.rayleigh_alpha, scene.rayleigh_beta);
    LowestModes lm = fem->lowest_modes(
      n_lowest, out_free, in_free, step.shift(),
      free_body ? options.inertial_modes.value_or(default_inertial_modes) : 0);
    nm             = static_cast<unsigned>(lm.w2.size());
    centrifugal    = std::move(lm.centrifugal);
    inertial       = std::move(lm.inertial);
    n_inertial     = lm.n_inertial;
    w2             = std::move(lm.w2);
    phi_out        = std::move(lm.shapes);
    compliance     = std::move(lm.compliance);
    rigid_w2_max   = lm.rigid_w2_max;
    if (free_body)
      {
        char line[256];
        std::snprintf(line, sizeof line,
                      "free body: the 6 rigid modes (|w^2| <= %.2e (rad/s)^2) by "
                      "shift-invert at -%.3g; inertia-relief static responses in %u "
                      "refinement passes (last relative correction %.1e)",
                      lm.rigid_w2_max, lm.rigid_shift, lm.refinement_passes,
                      lm.refinement_change);
        log(line);
      }
    rep.eigen_residual   = lm.largest_residual;
    rep.eigen_iterations = lm.iterations;
    rep.seconds_factor   = lm.seconds_factor;
    rep.seconds_lanczos  = lm.seconds_lanczos;
    rep.seconds_solves   = lm.seconds_solves;
    rep.seconds_static   = lm.seconds_static;
    phi_in.resize(static_cast<size_t>(nin) * nm);
    for (unsigned k = 0; k < nin; ++k)
      std::copy_n(&phi_out[static_cast<size_t>(3 * in_as_out[k / 3] + k % 3) * nm], nm,
                  &phi_in[static_cast<size_t>(k) * nm]);
  }

  /// Dense route (rank 0): every mode by LAPACK dsygvd; a free body's six rigid modes removed.
  void
  ImpulseResponsePrecompute::dense_modes()
  {
    const DenseSystem sys = fem->dense_free_system();
    // One BLAS thread: the eigenvectors' bits depend on the thread count, and a run
    // under mpirun (one core per rank) must give the serial run's file exactly.
    const int threads = openblas_get_num_threads ? openblas_get_num_threads() : 1;
    if (openblas_set_num_threads)
      openblas_set_num_threads(1);
    std::vector<double> phi = sys.stiffness, m = sys.mass; // phi: column-major
    w2.resize(n);
    const int itype = 1, N = static_cast<int>(n);
    int       info  = 0, lwork = -1, liwork = -1, iwq = 0;
    double    wq    = 0;
    dsygvd_(&itype, "V", "L", &N, phi.data(), &N, m.data(), &N, w2.data(), &wq, &lwork,
            &iwq, &liwork, &info);
    lwork  = static_cast<int>(wq);
    liwork = iwq;
    std::vector<double> work(lwork);
    std::vector<int>    iwork(liwork);
    dsygvd_(&itype, "V", "L", &N, phi.data(), &N, m.data(), &N, w2.data(), work.data(),
            &lwork, iwork.data(), &liwork, &info);
    if (openblas_set_num_threads)
      openblas_set_num_threads(threads);
    if (info != 0)
      throw std::runtime_error("dsygvd failed (info " + std::to_string(info) + ")");
    if (free_body)
      {
        // The rigid modes: six eigenvalues zero to round-off (a free body has exactly
        // six), well below the first elastic one. Whatever basis of that null space
        // LAPACK returns, the elastic modes are M-orthogonal to all of it, so dropping
        // the six is the mass-orthogonal separation of rigid motion.
        for (unsigned i = 0; i < n_rigid; ++i)
          rigid_w2_max = std::max(rigid_w2_max, std::abs(w2[i]));
        if (n <= n_rigid || !(rigid_w2_max < 1e-6 * w2[n_rigid]))
          throw InputError(
            "precompute: the free body's six lowest eigenvalues are not rigid modes "
            "(largest |w^2| " + std::to_string(rigid_w2_max) + " against the next, " +
            std::to_string(n > n_rigid ? w2[n_rigid] : 0.0) +
            "): is the mesh one connected body?");
        w2.erase(w2.begin(), w2.begin() + n_rigid);
      }
    // Row-major Phi restricted to the given free DoFs (the elastic modes only).
    const auto restrict_rows = [&](const std::vector<int> &free) {
      std::vector<double> r(free.size() * static_cast<size_t>(nm));
      for (size_t k = 0; k < free.size(); ++k)
        for (unsigned i = 0; i < nm; ++i)
          r[k * nm + i] = phi[static_cast<size_t>(i + n_rigid) * n + free[k]];
      return r;
    };
    phi_out = restrict_rows(out_free);
    phi_in  = restrict_rows(in_free);
    if (free_body)
      {
        centrifugal_loads(sys, phi);
        inertial_couplings(sys, phi);
      }
    if (rigid_fit)
      fit_route1(sys);
  }

  /// The free body's centrifugal loads of the elastic modes (phi: every mode, column-major).
  void
  ImpulseResponsePrecompute::centrifugal_loads(const DenseSystem &sys, const std::vector<double> &phi)
  {
    // M W, W the nine linear fields (n x 9, row-major), then Phi^T (M W).
    std::vector<double> mw(static_cast<size_t>(n) * 9, 0.0);
    for (unsigned r = 0; r < n; ++r)
      for (unsigned j = 0; j < n; ++j)
        {
          const double mrj = sys.mass[static_cast<size_t>(r) * n + j];
          if (mrj == 0)
            continue;
          const unsigned a = sys.free_dof_axis[j];
          for (unsigned c = 0; c < 3; ++c)
            mw[static_cast<size_t>(r) * 9 + 3 * a + c] += mrj * sys.free_dof_offset[j][c];
        }
    centrifugal.assign(static_cast<size_t>(nm) * 9, 0.0);
    for (unsigned i = 0; i < nm; ++i)
      {
        const double *col = &phi[static_cast<size_t>(i + n_rigid) * n];
        for (unsigned r = 0; r < n; ++r)
          for (unsigned e = 0; e < 9; ++e)
            centrifugal[static_cast<size_t>(i) * 9 + e] += col[r] * mw[static_cast<size_t>(r) * 9 + e];
      }
  }

  /// The free body's inertial couplings J_ab of its first n_inertial elastic modes (phi: every
  /// mode, column-major).
  void
  ImpulseResponsePrecompute::inertial_couplings(const DenseSystem &sys, const std::vector<double> &phi)
  {
    n_inertial = std::min(nm, options.inertial_modes.value_or(default_inertial_modes));
    const auto nodes = frame_couplings::node_triples(sys.free_dof_offset, sys.free_dof_axis);
    // M = M_s (x) I_3: the scalar mass from the x-components' rows.
    const auto      n_nodes = static_cast<Eigen::Index>(nodes.size());
    Eigen::MatrixXd Ms(n_nodes, n_nodes);
    for (Eigen::Index p = 0; p < n_nodes; ++p)
      for (Eigen::Index q = 0; q < n_nodes; ++q)
        Ms(p, q) = sys.mass[static_cast<size_t>(nodes[p][0]) * n + nodes[q][0]];
    std::array<Eigen::MatrixXd, 3> component, m_component; // [a] nodes x n_inertial
    for (int a = 0; a < 3; ++a)
      {
        component[a].resize(n_nodes, n_inertial);
        for (unsigned i = 0; i < n_inertial; ++i)
          for (Eigen::Index p = 0; p < n_nodes; ++p)
            component[a](p, i) = phi[static_cast<size_t>(i + n_rigid) * n + nodes[p][a]];
        m_component[a] = Ms * component[a];
      }
    inertial = frame_couplings::inertial_blocks(component, m_component);
  }

  /// Route 1: the best rigid fit taken out of every mode's output shape.
  void
  ImpulseResponsePrecompute::fit_route1(const DenseSystem &sys)
  {
    std::vector<std::array<double, 3>> x(nout / 3);
    std::vector<double>                weight(nout / 3, 1.0);
    for (unsigned v = 0; v < nout / 3; ++v)
      {
        x[v] = boundary.coordinates[out_v[v]];
        if (options.fit_weights == RigidFitWeights::mass)
          {
            const size_t i = static_cast<size_t>(out_free[3 * v]);
            weight[v]      = 0;
            for (unsigned j = 0; j < n; ++j) // row sum: the lumped mass
              weight[v] += sys.mass[static_cast<size_t>(j) * n + i];
          }
      }
    load_out = phi_out;
    const std::vector<double> share = remove_rigid_fit(phi_out, nm, x, weight);
    rep.rigid_fit_share_max  = *std::max_element(share.begin(), share.end());
    rep.rigid_fit_share_mean =
      std::accumulate(share.begin(), share.end(), 0.0) / share.size();
  }

  void
  ImpulseResponsePrecompute::modal_responses()
  {
    // 3. Modal responses h[s][i] and the energy left at T.
    h.assign(static_cast<size_t>(T) * nm, 0.0);
    std::vector<double> q(T), e0(nm), eT(nm), gain(nm);
    for (unsigned i = 0; i < nm; ++i)
      {
        modal_response(scene, coef, w2[i], q.data(), T, e0[i], eT[i]);
        for (unsigned s = 0; s < T; ++s)
          {
            h[static_cast<size_t>(s) * nm + i] = q[s];
            gain[i] += q[s]; // sum_{s<T} h_i[s]; the untruncated sum is the static gain 1/w^2
          }
      }
    {
      double sum = 0, sum_static = 0, captured_sum = 0;
      rep.static_in_modes_min = 1;
      for (unsigned k = 0; k < nin; ++k)
        {
          double a = 0, z = 0, g = 0, g_modes = 0;
          for (unsigned i = 0; i < nm; ++i)
            {
              const double p2 = phi_in[static_cast<size_t>(k) * nm + i] * phi_in[static_cast<size_t>(k) * nm + i];
              a += p2 * eT[i];
              z += p2 * e0[i];
              g += p2 * gain[i];
              g_modes += p2 / w2[i];
            }
          // The driving-point static compliance (K^-1)_kk: all modes, or the sparse solve.
          const unsigned kk    = 3 * in_as_out[k / 3] + k % 3;
          const double   g_all = sparse ? compliance[static_cast<size_t>(kk) * nin + k] : g_modes;
          rep.energy_left_max = std::max(rep.energy_left_max, a / z);
          sum += a / z;
          rep.static_left_max = std::max(rep.static_left_max, std::abs(1 - g / g_all));
          sum_static += std::abs(1 - g / g_all);
          // The lowest modes' share (the residual modes carry the rest). The modes are stored
          // ascending and the residual modes lie above the lowest (they are M-orthogonal to
          // them), so the lowest are the first n_lowest (every mode on the dense route).
          double g_lowest = 0;
          for (unsigned i = 0; i < n_lowest; ++i)
            g_lowest += phi_in[static_cast<size_t>(k) * nm + i] *
                          phi_in[static_cast<size_t>(k) * nm + i] / w2[i];
          rep.static_in_modes_min = std::min(rep.static_in_modes_min, g_lowest / g_all);
          captured_sum += g_lowest / g_all;
          rep.static_basis_error_max =
            std::max(rep.static_basis_error_max, std::abs(g_modes / g_all - 1));
        }
      rep.energy_left_mean    = sum / nin;
      rep.static_left_mean    = sum_static / nin;
      rep.static_in_modes_mean = captured_sum / nin;
    }
    log("energy left after T = " + std::to_string(T) + " steps: mean " +
        std::to_string(rep.energy_left_mean) + ", max " + std::to_string(rep.energy_left_max) +
        "; static compliance missing: mean " + std::to_string(rep.static_left_mean) + ", max " +
        std::to_string(rep.static_left_max));
    if (sparse)
      log("static compliance at the inputs in the lowest " + std::to_string(n_lowest) +
          " modes: mean " + std::to_string(rep.static_in_modes_mean) + ", least " +
          std::to_string(rep.static_in_modes_min) + "; with the " +
          std::to_string(nm - n_lowest) + " residual modes: error " +
          fmt(rep.static_basis_error_max, "%.2g") + " (exact: round-off)");

    live = live_modes(h, phi_in, phi_out, T, nm,
                                      options.every_mode_every_step
                                        ? 0.0
                                        : 0.1 * (rep.double_storage ? 0x1p-53 : 0x1p-24));
    rep.gemm_work = live.work;
    log("modes alive: all " + std::to_string(nm) + " at step 0, " +
        std::to_string(live.alive[T / 2]) + " at step " + std::to_string(T / 2) + ", " +
        std::to_string(live.alive[T - 1]) + " at the last; the responses' GEMM is " +
        std::to_string(100 * live.work) + " % of all modes at every step");
  }

  void
  ImpulseResponsePrecompute::open_output()
  {
    // 4. The file: metadata first, then H in chunks of inputs, each marked done when written.
    per_input = static_cast<size_t>(T) * nout;
    scalar    = rep.double_storage ? 8 : 4;
    // A chunk never holds more inputs than there are (a larger --chunk is clamped).
    chunk = std::min<unsigned>(
      nin, options.inputs_per_chunk > 0
             ? options.inputs_per_chunk
             : static_cast<unsigned>(std::clamp<size_t>(64000000 / (per_input * scalar), 1, 256)));
    n_chunks = (nin + chunk - 1) / chunk;
    rep.n_chunks = n_chunks;
    rep.modal_only = options.modal_only;
    rep.bytes      = options.modal_only ? 0.0 : static_cast<double>(per_input) * nin * scalar;
    // Reciprocity (Maxwell-Betti): with the same vertices in and out, in the same order,
    // H[s] = Phi diag(h[s]) Phi^T is symmetric. Each chunk then computes only the outputs from
    // its own first input on (half the GEMM) and takes the outputs before it from the chunks
    // already computed, transposed. Those blocks wait on the writing rank until their chunk is
    // written: at most about a quarter of H.
    symmetric = in_v == out_v && !rigid_fit; // route 1's H is not symmetric
    {
      // Before the long part: the chunk buffers (two sets on one rank: one computing, one
      // writing) and GEMM operands of every worker, the blocks reciprocity keeps, and the file.
      const double workers_max = size == 1 ? 2 * 4 : 1;
      const double buffers     = options.modal_only
                                   ? 0.0
                                   : workers_max * chunk * (per_input + static_cast<double>(T) * nm) *
                                         (scalar + 8) +
                                       (symmetric && rank == 0 ? rep.bytes / 4 : 0);
      check_memory_estimate("precompute (--chunk " + std::to_string(chunk) + ")", buffers,
                            options.allow_large);
      if (rank == 0)
        check_disk_estimate("the model", options.output, rep.bytes, options.allow_large);
    }

    const std::string spec_id = spec_id_of();
    done.assign(n_chunks, 0);
    const auto t0 = Clock::now();
    if (rank == 0)
      {
        w = std::make_unique<h5::Writer>(options.output,
                                         options.restart ? h5::Writer::Mode::create
                                                         : h5::Writer::Mode::resume,
                                         std::move(output_lock));
        w->keep_partial(true);
        if (w->discarded_unreadable_part())
          log("the partial file " + options.output + ".part was unreadable (a run that failed "
              "mid-write): starting over");
        // A part file whose spec or progress does not fit this run's chunks (or cannot be read)
        // is another run's: it is started over below, never indexed past its end.
        std::vector<long long> progress;
        if (w->resumed())
          try
            {
              if (w->string_attribute("/", "spec_id") == spec_id &&
                  w->exists("/progress/chunk_done"))
                progress = w->read_int("/progress/chunk_done");
            }
          catch (const InputError &)
            {
              progress.clear();
            }
        if (!progress.empty() && progress.size() == n_chunks)
          {
            done = progress;
            for (const auto x : done)
              rep.chunks_resumed += x != 0;
            log("resuming " + options.output + ".part: " + std::to_string(rep.chunks_resumed) +
                " of " + std::to_string(n_chunks) + " chunks already done");
          }
        else
          {
            if (w->resumed())
              {
                log("the partial file " + options.output + ".part is from another spec: starting over");
                w->start_over();
              }
            write_metadata(*w, spec_id);
          }
      }
    MPI_Bcast(done.data(), n_chunks, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
    write_seconds += since(t0);
  }

  /// What makes a part file this run's: the mesh, material, integrator, step, length, storage,
  /// chunks, route and vertex sets.
  std::string
  ImpulseResponsePrecompute::spec_id_of() const
  {
    const std::string  mesh_hash = file_hash(scene.mesh_file);
    std::ostringstream spec;
    spec.precision(17);
    spec << "mesh " << mesh_hash << " p " << scene.fe_degree << " E "
         << scene.youngs_modulus << " nu " << scene.poisson_ratio << " rho " << scene.density
         << " a " << scene.rayleigh_alpha << " b " << scene.rayleigh_beta << " int "
         << static_cast<int>(scene.integrator) << " rho_inf " << scene.rho_inf << " dt "
         << scene.time_step << " T " << T << " dbl " << rep.double_storage << " chunk " << chunk
         << " fixed " << join(scene.fixed_surfaces);
    if (sparse)
      spec << " modes " << n_lowest;
    if (rigid_fit)
      spec << " rigid_fit " << static_cast<int>(options.fit_weights);
    if (options.modal_only)
      spec << " modal_only";
    if (free_body)
      spec << " inertial " << n_inertial;
    spec << " live " << live.tolerance;
    spec << " in";
    for (const unsigned v : in_v)
      spec << ' ' << boundary.node_tags[v];
    spec << " out";
    for (const unsigned v : out_v)
      spec << ' ' << boundary.node_tags[v];
    return std::to_string(std::hash<std::string>{}(spec.str()));
  }

  /// The model's attributes and provenance, and a free body's rigid-body data.
  void
  ImpulseResponsePrecompute::write_metadata(h5::Writer &f, const std::string &spec_id)
  {
    f.attribute("/", "format", std::string("irdm-impulse-response"));
    // Version 3: H not stored (modal_only); a build that reads only 1 and 2 then
    // refuses the file by its version rather than by a missing dataset.
    f.attribute("/", "format_version", options.modal_only ? 3LL : 2LL);
    write_provenance(f, scene, coef);
    f.attribute("/", "spec_id", spec_id);
    f.attribute("/", "units", std::string("SI: m, s, N, kg, Pa; H in m/N"));
    f.attribute("/", "convention",
                std::string("u[n] = sum_s H[s] f[n-s]; f[n] is the force held during "
                            "step n (impulse = f * time_step); H[s] is the FEM "
                            "displacement s steps after a unit force sample at step "
                            "0 from rest; H[0] is the direct feed-through; IRDM "
                            "step n is FEM time (n+1)*time_step"));
    f.attribute("/", "length", static_cast<long long>(T));
    f.attribute("/", "storage", std::string(rep.double_storage ? "double" : "float"));
    f.attribute("/", "route",
                sparse ? "modal (the lowest " + std::to_string(n_lowest) + " of " +
                           std::to_string(n) + " modes by shift-invert block Lanczos, plus " +
                           std::to_string(nm - n_lowest) + " residual modes of "
                           "the inputs' static and one-step responses" +
                           (free_body ? std::string("; free body: the 6 rigid-body "
                                                    "modes removed, mass-orthogonal, "
                                                    "static responses in the inertia-"
                                                    "relief form") : std::string()) +
                           ")"
                       : rigid_fit
                           ? std::string("rigid fit, free body (the whole response "
                                         "minus its best rigid fit at every sample: "
                                         "linear least squares over the outputs, ") +
                               weights_name + " weights; all elastic modes, exact)"
                       : free_body
                           ? std::string("modal, free body (the 6 rigid-body modes "
                                         "removed, mass-orthogonal; all elastic "
                                         "modes, exact)")
                           : std::string("modal (all modes, exact)"));
    f.attribute("/", "body", std::string(free_body ? "free" : "fixed"));
    if (free_body)
      {
        f.attribute("/", "free_body_route",
                    std::string(rigid_fit ? "rigid_fit" : "modal"));
        if (rigid_fit)
          f.attribute("/", "rigid_fit_weights", std::string(weights_name));
      }
    if (free_body)
      {
        // What the runtime's rigid-body dynamics needs, from the mesh (exact for
        // straight tetrahedra, uniform density).
        const MassProperties mp =
          mass_properties(read_gmsh(scene.mesh_file), scene.density);
        f.create_group("/rigid_body");
        f.write("/rigid_body/mass_kg", {1}, &mp.mass);
        f.write("/rigid_body/center_of_mass_m", {3}, mp.center.data());
        f.write("/rigid_body/inertia_kg_m2", {3, 3}, &mp.inertia[0][0]);
        f.attribute("/rigid_body", "rigid_modes_removed", static_cast<long long>(n_rigid));
        f.attribute("/rigid_body", "rigid_modes_largest_w2", rigid_w2_max);
        f.attribute("/rigid_body", "frame",
                    std::string("model (mesh) frame; inertia about the centre of mass"));
      }
    f.attribute("/", "free_dofs", static_cast<long long>(n));
    f.attribute("/", "modes_kept", static_cast<long long>(nm));
    f.attribute("/", "modes_lowest", static_cast<long long>(n_lowest));

    write_geometry_and_modes(f);
  }

  /// The vertices, the surface, the modal realization, and H's dataset with its progress.
  void
  ImpulseResponsePrecompute::write_geometry_and_modes(h5::Writer &f)
  {
    const auto write_vertices = [&](const std::string &g, const std::vector<unsigned> &vs) {
      f.create_group(g);
      std::vector<long long> tags;
      std::vector<double>    xyz;
      for (const unsigned v : vs)
        {
          tags.push_back(boundary.node_tags[v]);
          xyz.insert(xyz.end(), boundary.coordinates[v].begin(), boundary.coordinates[v].end());
        }
      f.write(g + "/node_tags", {vs.size()}, tags.data());
      f.write(g + "/coordinates", {vs.size(), 3}, xyz.data());
    };
    write_vertices("/outputs", out_v);
    write_vertices("/inputs", in_v);
    // Inputs as rows of the outputs (so the contact solve can read H_CC).
    const std::vector<long long> output_index(in_as_out.begin(), in_as_out.end());
    f.write("/inputs/output_index", {output_index.size()}, output_index.data());

    // Surface triangles among the outputs, for display and for probes.
    std::vector<long long> local(boundary.mesh_vertex.size(), -1), tris, tri_surface;
    for (size_t i = 0; i < out_v.size(); ++i)
      local[out_v[i]] = static_cast<long long>(i);
    std::vector<std::string> names;
    for (unsigned t = 0; t < boundary.triangles.size(); ++t)
      {
        const auto &tri = boundary.triangles[t];
        if (local[tri[0]] < 0 || local[tri[1]] < 0 || local[tri[2]] < 0)
          continue;
        for (const unsigned v : tri)
          tris.push_back(local[v]);
        auto it = std::find(names.begin(), names.end(), boundary.triangle_surface[t]);
        if (it == names.end())
          it = names.insert(names.end(), boundary.triangle_surface[t]);
        tri_surface.push_back(it - names.begin());
      }
    f.create_group("/surface");
    f.write("/surface/triangles", {tri_surface.size(), 3}, tris.data());
    f.write("/surface/triangle_surface", {tri_surface.size()}, tri_surface.data());
    f.attribute("/surface", "surface_names", join(names));

    f.create_group("/modes");
    std::vector<double> hz(nm), zeta(nm);
    for (unsigned i = 0; i < nm; ++i)
      {
        const double wi = std::sqrt(w2[i]);
        hz[i]   = wi / (2 * M_PI);
        zeta[i] = (scene.rayleigh_alpha + scene.rayleigh_beta * w2[i]) / (2 * wi);
      }
    f.write("/modes/frequency_Hz", {nm}, hz.data());
    f.write("/modes/damping_ratio", {nm}, zeta.data());
    // The modal realization of H: mode shapes at the outputs (M-orthonormal) and
    // each mode's step matrix; H[s] = Phi_out diag(q_i[s]) Phi_in^T with q_i from
    // iterating the step (docs/model-format.md).
    f.write("/modes/shapes", {nout, nm}, phi_out.data());
    if (rigid_fit) // H[s] = shapes diag(q[s]) load_shapes(inputs)^T
      f.write("/modes/load_shapes", {nout, nm}, load_out.data());
    std::vector<double> steps(static_cast<size_t>(nm) * 15);
    for (unsigned i = 0; i < nm; ++i)
      {
        const auto m = ModalStep(scene, coef, w2[i]).matrix();
        std::copy(m.begin(), m.end(), steps.begin() + 15 * i);
      }
    f.write("/modes/step", {nm, 3, 5}, steps.data());
    if (!centrifugal.empty())
      {
        f.write("/modes/centrifugal_load", {nm, 3, 3}, centrifugal.data());
        f.attribute("/modes/centrifugal_load", "meaning",
                    std::string("[mode i][a][b] = phi_i^T M w_ab, w_ab the field e_a (x_b "
                                "- c_b), c the centre of mass (kg m per unit modal "
                                "coordinate): a spin omega (rad/s, model frame) loads "
                                "mode i by sum_ab S_ab [i][a][b] N, S = |omega|^2 I - "
                                "omega omega^T, the centrifugal force -M (omega x "
                                "(omega x r))"));
      }
    if (!inertial.empty())
      {
        f.write("/modes/inertial_coupling", {3, 3, n_inertial, n_inertial}, inertial.data());
        f.attribute("/modes/inertial_coupling", "meaning",
                    std::string("[a][b][i][j] = phi_i,a^T M_s phi_j,b over the first modes "
                                "(kg per unit modal coordinates squared; phi_i,a the a-components "
                                "of mode i, M = M_s (x) I_3): the frame's Euler, spin-softening "
                                "and Coriolis forces on the deformation (docs/free-body.md)"));
      }

    if (options.modal_only)
      {
        f.attribute("/", "impulse_response",
                    std::string("modal realization only: /impulse_response/H is not "
                                "stored; H[s] = shapes diag(q[s]) L(inputs)^T, L the "
                                "load_shapes if present, else the shapes, q from "
                                "/modes/step"));
        f.flush();
      }
    else
      {
        f.create_group("/impulse_response");
        f.create_dataset("/impulse_response/H", {nin, T, nout}, rep.double_storage, 1, true);
        f.attribute("/impulse_response/H", "layout",
                    std::string("[input DoF][step s][output DoF]; DoF = 3 * vertex + axis"));
        f.attribute("/impulse_response/H", "modes_left_out_below_m_per_N", live.tolerance);
        f.attribute("/impulse_response/H", "modes_left_out",
                    std::string("each mode is summed up to its last step whose term can "
                                "exceed modes_left_out_below_m_per_N / modes_kept in any "
                                "entry; what is left out of an entry is at most "
                                "modes_left_out_below_m_per_N (a tenth of the storage's "
                                "unit round-off times the largest driving-point response)"));
        f.create_group("/progress");
        f.write("/progress/chunk_done", {n_chunks}, done.data());
        f.flush();
      }
  }

  void
  ImpulseResponsePrecompute::write_responses()
  {
    // 5. Chunks: A[(k, s), i] = h[s][i] phi_in[k][i] over the modes alive at step s
    //    (live_modes), then H_chunk = A Phi_out^T, one GEMM per input and block of steps.
    //    Chunk c belongs to rank c % size; rank 0 receives and writes in order.
    //    phi_out_s: Phi_out in the storage precision, its modes in live order, converted once.
    // h and Phi_in with their modes in live order, so that a row of A is a contiguous product.
    h_live.resize(h.size());
    phi_in_live.resize(phi_in.size());
    for (size_t r = 0; r < h.size() / nm; ++r)
      for (unsigned i = 0; i < nm; ++i)
        h_live[r * nm + i] = h[r * nm + live.order[i]];
    for (size_t r = 0; r < phi_in.size() / nm; ++r)
      for (unsigned i = 0; i < nm; ++i)
        phi_in_live[r * nm + i] = phi_in[r * nm + live.order[i]];
    // Each GEMM runs on one BLAS thread so that a chunk's bits do not depend on how the work
    // is split; a serial run computes several chunks at once on threads of its own instead.
    const int blas_threads = openblas_get_num_threads ? openblas_get_num_threads() : 1;
    if (openblas_set_num_threads)
      openblas_set_num_threads(1);
    workers =
      size == 1 ? std::max(1u, std::min(4u, std::thread::hardware_concurrency())) : 1u;
    double compute_seconds = options.modal_only  ? 0.0
                             : rep.double_storage ? run_chunks<double>()
                                                  : run_chunks<float>();
    if (openblas_set_num_threads)
      openblas_set_num_threads(blas_threads);
    MPI_Allreduce(MPI_IN_PLACE, &compute_seconds, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    rep.seconds_responses = compute_seconds;
    if (rank == 0)
      {
        const auto tw = Clock::now();
        w->attribute("/", "precompute_ranks", static_cast<long long>(size));
        const double direct_mb = w->bytes_written_directly() / 1e6;
        w->commit();
        write_seconds += since(tw);
        if (!options.modal_only)
          log("H: " + std::to_string(static_cast<long long>(direct_mb)) +
              " MB written past the page cache (O_DIRECT), the rest through HDF5");
      }
    rep.seconds_write = write_seconds;
    rep.seconds_total = since(t_start);
    log("wrote " + options.output + " (" +
        (options.modal_only ? std::string("the modal realization only, no H")
                            : std::to_string(rep.bytes / 1e6) + " MB of H") + ") in " +
        std::to_string(rep.seconds_total) + " s");
  }

  template <class Scalar>
  void
  ImpulseResponsePrecompute::compute_chunk(const unsigned c, const std::vector<Scalar> &phi_out_s, Scalar *result) const
  {
    const unsigned k0 = c * chunk, nk = std::min(chunk, nin - k0);
    const unsigned j0 = symmetric ? k0 : 0; // the outputs before j0 come by reciprocity
    const size_t   nj = nout - j0;
    // Per block of steps, one GEMM over every input of the chunk (rows (k, s), k-major), so
    // that each call is large; its rows then go to their places in the chunk.
    std::vector<Scalar> A, C;
    for (size_t b = 0; b + 1 < live.block.size(); ++b)
      {
        const unsigned s0 = live.block[b], len = live.block[b + 1] - s0, m = live.width[b];
        const auto     row_of = [&](const unsigned k, const unsigned s) {
          return result + (static_cast<size_t>(k) * T + s0 + s) * nout + j0;
        };
        if (m == 0) // every mode has died out: nothing left above the round-off
          {
            for (unsigned k = 0; k < nk; ++k)
              for (unsigned s = 0; s < len; ++s)
                std::fill(row_of(k, s), row_of(k, s) + nj, Scalar(0));
            continue;
          }
        const size_t rows = static_cast<size_t>(nk) * len;
        A.resize(rows * m);
        C.resize(rows * nj);
        for (unsigned k = 0; k < nk; ++k)
          for (unsigned s = 0; s < len; ++s)
            {
              Scalar       *row = &A[(static_cast<size_t>(k) * len + s) * m];
              const double *hs  = &h_live[static_cast<size_t>(s0 + s) * nm];
              const double *pk  = &phi_in_live[static_cast<size_t>(k0 + k) * nm];
              for (unsigned i = 0; i < m; ++i)
                row[i] = static_cast<Scalar>(hs[i] * pk[i]);
            }
        gemm_abt(static_cast<int>(rows), static_cast<int>(nj), static_cast<int>(m), A.data(),
                 static_cast<int>(m), phi_out_s.data() + static_cast<size_t>(j0) * nm,
                 static_cast<int>(nm), C.data(), static_cast<int>(nj));
        for (unsigned k = 0; k < nk; ++k)
          for (unsigned s = 0; s < len; ++s)
            std::copy_n(&C[(static_cast<size_t>(k) * len + s) * nj], nj, row_of(k, s));
      }
  }

  template <class Scalar>
  double
  ImpulseResponsePrecompute::run_chunks()
  {
    const MPI_Datatype        type = sizeof(Scalar) == 8 ? MPI_DOUBLE : MPI_FLOAT;
    std::vector<Scalar> phi_out_s(phi_out.size());
    for (size_t j = 0; j < nout; ++j)
      for (unsigned i = 0; i < nm; ++i)
        phi_out_s[j * nm + i] = static_cast<Scalar>(phi_out[j * nm + live.order[i]]);
    // Two sets of buffers on one rank: the GEMMs of one batch fill one set while the other
    // set, the batch before, is being written.
    const unsigned n_sets = size == 1 ? 2 : 1;
    std::vector<std::vector<Scalar>> buffers(n_sets * workers,
                                             std::vector<Scalar>(static_cast<size_t>(chunk) * per_input));
    double     compute_seconds = 0, fill_seconds = 0;
    unsigned   finished        = rep.chunks_resumed;
    const auto t_chunks        = Clock::now(); // the time left is estimated from this run's rate
    const auto store = [&](const unsigned c, const Scalar *data) {
      const unsigned k0 = c * chunk, nk = std::min(chunk, nin - k0);
      const auto     tw = Clock::now();
      w->write_rows("/impulse_response/H", k0, nk, data);
      const long long one = 1;
      w->write_rows("/progress/chunk_done", c, 1, &one);
      w->flush();
      write_seconds += since(tw);
      ++finished;
      const double per_chunk = since(t_chunks) / (finished - rep.chunks_resumed);
      log("chunk " + std::to_string(finished) + "/" + std::to_string(n_chunks) + " (inputs " +
          std::to_string(k0) + ".." + std::to_string(k0 + nk - 1) + "), " +
          std::to_string(static_cast<int>(since(t_start))) + " s elapsed, about " +
          std::to_string(static_cast<int>(per_chunk * (n_chunks - finished))) + " s left");
    };
    // Reciprocity, on the writing rank, chunk by chunk in order: chunk c's outputs before
    // its first input from the blocks earlier chunks left for it (and its own block's lower
    // triangle from its upper), then the blocks it leaves for later chunks:
    // block[c2][c] = H[inputs of c][s][outputs of c2], [k][s][j].
    std::vector<std::vector<std::vector<Scalar>>> block(
      symmetric ? n_chunks : 0, std::vector<std::vector<Scalar>>(n_chunks));
    const auto complete = [&](const unsigned c, Scalar *data) { fill_by_reciprocity(c, data, block); };
    // Chunks to compute: those not written yet; under reciprocity every chunk (a resumed run
    // recomputes the written ones for the blocks they leave, without writing them again).
    std::vector<unsigned> todo;
    for (unsigned c = 0; c < n_chunks; ++c)
      if (!done[c] || symmetric)
        todo.push_back(c);
    if (size == 1)
      {
        std::future<void> writing; // the batch before, written while this batch computes
        for (size_t first = 0, batch = 0; first < todo.size(); first += workers, ++batch)
          {
            const size_t n_batch = std::min<size_t>(workers, todo.size() - first);
            const auto   buffer  = [&, batch](const size_t b) {
              return buffers[(batch % n_sets) * workers + b].data();
            };
            const auto tc = Clock::now();
            std::vector<std::thread> pool;
            for (size_t b = 1; b < n_batch; ++b)
              pool.emplace_back([&, b] { compute_chunk(todo[first + b], phi_out_s, buffer(b)); });
            compute_chunk(todo[first], phi_out_s, buffer(0));
            for (auto &t : pool)
              t.join();
            const auto tf = Clock::now();
            for (size_t b = 0; b < n_batch; ++b)
              complete(todo[first + b], buffer(b));
            fill_seconds += since(tf);
            compute_seconds += since(tc);
            if (writing.valid())
              writing.get(); // rethrows a failed write
            writing = std::async(std::launch::async, [&, first, n_batch, buffer] {
              for (size_t b = 0; b < n_batch; ++b)
                if (!done[todo[first + b]])
                  store(todo[first + b], buffer(b));
            });
          }
        if (writing.valid())
          writing.get();
        if (symmetric)
          log("responses: " + std::to_string(compute_seconds) + " s, of which the fill by "
              "reciprocity " + std::to_string(fill_seconds) + " s");
      }
    else
      for (const unsigned c : todo)
        {
          const int      owner = static_cast<int>(c % size);
          const unsigned k0 = c * chunk, nk = std::min(chunk, nin - k0);
          const size_t   count = static_cast<size_t>(nk) * per_input;
          if (owner == rank)
            {
              const auto tc = Clock::now();
              compute_chunk(c, phi_out_s, buffers[0].data());
              compute_seconds += since(tc);
              if (rank != 0)
                MPI_Send(buffers[0].data(), static_cast<int>(count), type, 0,
                         static_cast<int>(c), MPI_COMM_WORLD);
            }
          else if (rank == 0)
            MPI_Recv(buffers[0].data(), static_cast<int>(count), type, owner,
                     static_cast<int>(c), MPI_COMM_WORLD, MPI_STATUS_IGNORE);
          if (rank == 0)
            {
              complete(c, buffers[0].data());
              if (!done[c])
                store(c, buffers[0].data());
            }
        }
    return compute_seconds;
  }

  /// Reciprocity, on the writing rank, chunk by chunk in order: chunk c's outputs before its
  /// first input from the blocks earlier chunks left for it (and its own block's lower
  /// triangle from its upper), then the blocks it leaves for later chunks:
  /// block[c2][c] = H[inputs of c][s][outputs of c2], [k][s][j].
  template <class Scalar>
  void
  ImpulseResponsePrecompute::fill_by_reciprocity(const unsigned c, Scalar *data,
                                                 std::vector<std::vector<std::vector<Scalar>>> &block) const
  {
    if (!symmetric)
      return;
    const unsigned k0 = c * chunk, nk = std::min(chunk, nin - k0);
    for (unsigned c1 = 0; c1 < c; ++c1)
      {
        const unsigned j0 = c1 * chunk, nj = std::min(chunk, nin - j0);
        const Scalar  *from = block[c][c1].data(); // [j][s][k]: H[j][s][k] = H[k][s][j]
        // k innermost: the reads run along `from`, the writes go to nk rows side by side.
        for (unsigned s = 0; s < T; ++s)
          for (unsigned j = 0; j < nj; ++j)
            {
              const Scalar *in = from + (static_cast<size_t>(j) * T + s) * nk;
              for (unsigned k = 0; k < nk; ++k)
                data[(static_cast<size_t>(k) * T + s) * nout + j0 + j] = in[k];
            }
        std::vector<Scalar>().swap(block[c][c1]);
      }
    // Within the chunk's own block, below its diagonal too: the stored H[s] is then exactly
    // symmetric.
    for (unsigned k = 1; k < nk; ++k)
      for (unsigned s = 0; s < T; ++s)
        for (unsigned j = 0; j < k; ++j)
          data[(static_cast<size_t>(k) * T + s) * nout + k0 + j] =
            data[(static_cast<size_t>(j) * T + s) * nout + k0 + k];
    for (unsigned c2 = c + 1; c2 < n_chunks; ++c2)
      {
        const unsigned j0 = c2 * chunk, nj = std::min(chunk, nin - j0);
        auto          &to = block[c2][c];
        to.resize(static_cast<size_t>(nk) * T * nj);
        for (size_t r = 0; r < static_cast<size_t>(nk) * T; ++r)
          std::copy(data + r * nout + j0, data + r * nout + j0 + nj, to.data() + r * nj);
      }
  }

  PrecomputeReport
  ImpulseResponsePrecompute::run()
  {
    setup();
    compute_modes();
    modal_responses();
    open_output();
    write_responses();
    return rep;
  }

  PrecomputeReport
  precompute_impulse_responses(const Scene &scene, const PrecomputeOptions &options)
  {
    return ImpulseResponsePrecompute(scene, options).run();
  }
} // namespace irdm::fem
