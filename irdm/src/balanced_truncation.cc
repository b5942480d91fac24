// Balanced truncation of the modal realization (irdm/state_space_model.h): the peer of ERA for
// a model whose modes and integrator are known.
#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "realization.h"

namespace irdm
{
  using realization::Mat;
  using realization::Vec;

  struct BalancedGramians
  {
    BalancedOptions              options;
    unsigned                     n_modes = 0;
    std::vector<Eigen::Matrix3d> A;    // per mode
    std::vector<Eigen::Vector3d> beta; // per mode: A b_new + b_old, the state a unit load enters
    Mat                          phi_out, load_in; // n_out x N, n_in x N
    Mat                          Lp, Lq;           // P = Lp Lp^T, Q = Lq Lq^T (n x rank)
    realization::Svd             svd;              // of Lq^T Lp, leading options.order + 30
    double                       tail_energy = 0;  // sum of the squared singular values beyond svd's
    bool                         complete    = false; // svd holds every singular value
    double                       seconds     = 0;
  };

  namespace
  {
    /// A factor F (n x k) with F F^T = S to round-off for a symmetric positive semi-definite
    /// S: Cholesky with complete pivoting, stopped where every remaining pivot is below 1e-15
    /// of the largest diagonal entry (Higham, Accuracy and Stability, 10.3). The directions it
    /// leaves out are states no input reaches (or no output sees) to round-off; a plain or
    /// LDL^T factorization divides by those pivots' noise.
    Mat
    psd_factor(const Mat &S, const char *name)
    {
      const Eigen::Index n       = S.rows();
      Vec                d       = S.diagonal();
      const double       largest = d.maxCoeff();
      if (!(largest > 0))
        throw InputError(std::string("balanced truncation: the ") + name + " Gramian is zero");
      Mat          F(n, n);
      Eigen::Index k = 0;
      for (; k < n; ++k)
        {
          Eigen::Index j;
          if (!(d.maxCoeff(&j) > 1e-15 * largest))
            break;
          Vec col = S.col(j);
          col.noalias() -= F.leftCols(k) * F.row(j).leftCols(k).transpose();
          col /= std::sqrt(d[j]);
          F.col(k) = col;
          d -= col.cwiseAbs2();
          d[j] = 0; // chosen: its residual is zero by construction
        }
      return F.leftCols(k);
    }

    /// The Gramians' blocks for the modes i, j: (I - A_j (x) A_i) vec P_ij = vec(beta_i beta_j^T)
    /// G_in(i, j) and its transpose for Q_ij with e_u e_u^T G_out(i, j) (vec column-major:
    /// vec(X Y Z) = (Z^T (x) X) vec Y).
    void
    gramian_blocks(const BalancedGramians &g, const Mat &G_in, const Mat &G_out, Mat &P, Mat &Q)
    {
      using Mat9 = Eigen::Matrix<double, 9, 9>;
      using Vec9 = Eigen::Matrix<double, 9, 1>;
      const unsigned N = g.n_modes;
      for (unsigned i = 0; i < N; ++i)
        for (unsigned j = i; j < N; ++j)
          {
            Mat9 K = Mat9::Identity();
            for (int c = 0; c < 3; ++c)
              for (int c2 = 0; c2 < 3; ++c2)
                for (int r = 0; r < 3; ++r)
                  for (int r2 = 0; r2 < 3; ++r2)
                    K(r + 3 * c, r2 + 3 * c2) -= g.A[j](c, c2) * g.A[i](r, r2);
            const Eigen::PartialPivLU<Mat9> lu(K);
            Vec9 wp, wq = Vec9::Zero();
            Eigen::Map<Eigen::Matrix3d>(wp.data()) = g.beta[i] * g.beta[j].transpose() * G_in(i, j);
            wq(0) = G_out(i, j); // e_u e_u^T: the displacement is each block's first state
            const Vec9 xp = lu.solve(wp), xq = lu.transpose().solve(wq);
            const Eigen::Map<const Eigen::Matrix3d> Pij(xp.data()), Qij(xq.data());
            P.block<3, 3>(3 * i, 3 * j) = Pij;
            P.block<3, 3>(3 * j, 3 * i) = Pij.transpose();
            Q.block<3, 3>(3 * i, 3 * j) = Qij;
            Q.block<3, 3>(3 * j, 3 * i) = Qij.transpose();
          }
    }
  } // namespace

  std::shared_ptr<const BalancedGramians>
  prepare_balanced(const ImpulseResponseModel &m, const BalancedOptions &o)
  {
    const auto t0  = std::chrono::steady_clock::now();
    const auto log = [&](const std::string &s) {
      if (o.log)
        o.log(s);
    };
    const ModalData &md = m.modes;
    if (md.n_modes == 0)
      throw InputError("balanced truncation: the model holds no modal realization (/modes); "
                       "precompute it with its modes, or use --method era (from H alone)");
    if (m.free_body)
      throw InputError("balanced truncation: a free body's rigid modes have no finite Gramian");
    const unsigned N = md.n_modes, n = 3 * N, nin = m.n_inputs, nout = m.n_outputs;
    if (o.order == 0 || o.order > n)
      throw InputError("balanced truncation: order " + std::to_string(o.order) +
                       " is not within 1 .. " + std::to_string(n) + " (3 states per mode)");
    if (!(o.stability_radius > 0 && o.stability_radius <= 1 - 1e-9))
      throw InputError("balanced truncation: the stability radius must be in (0, 1 - 1e-9]");
    check_memory_estimate("balanced truncation of " + std::to_string(N) + " modes",
                          8.0 * 5 * static_cast<double>(n) * n, false);
    auto g     = std::make_shared<BalancedGramians>();
    g->options = o;
    g->n_modes = N;
    for (unsigned i = 0; i < N; ++i)
      {
        const double   *s = &md.step[15 * static_cast<size_t>(i)];
        Eigen::Matrix3d A;
        Eigen::Vector3d b_new, b_old;
        for (int r = 0; r < 3; ++r)
          {
            for (int c = 0; c < 3; ++c)
              A(r, c) = s[5 * r + c];
            b_new(r) = s[5 * r + 3], b_old(r) = s[5 * r + 4];
          }
        g->A.push_back(A);
        g->beta.push_back(A * b_new + b_old);
        if (!(A.eigenvalues().cwiseAbs().maxCoeff() < 1))
          throw InputError("balanced truncation: mode " + std::to_string(i) +
                           "'s step is not stable (an undamped or rigid mode has no finite Gramian)");
      }
    const std::vector<double> &load = md.load_shapes.empty() ? md.shapes : md.load_shapes;
    g->phi_out = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      md.shapes.data(), nout, N);
    g->load_in.resize(nin, N);
    for (unsigned k = 0; k < nin; ++k)
      for (unsigned i = 0; i < N; ++i)
        g->load_in(k, i) = load[static_cast<size_t>(3 * m.input_output_index[k / 3] + k % 3) * N + i];
    log("balanced truncation: Gramians of " + std::to_string(N) + " modes (" + std::to_string(n) +
        " states)");
    Mat P(n, n), Q(n, n);
    if (!(o.contact_weight >= 1 && std::isfinite(o.contact_weight)))
      throw InputError("balanced truncation: the contact weight must be at least 1");
    Mat weighted = g->phi_out; // C^T W^2 C: the contact rows weighed
    for (unsigned k = 0; k < nin; ++k)
      weighted.row(3 * m.input_output_index[k / 3] + k % 3) *= o.contact_weight;
    gramian_blocks(*g, g->load_in.transpose() * g->load_in, weighted.transpose() * weighted, P, Q);
    g->Lp = psd_factor(P, "controllability");
    P.resize(0, 0);
    g->Lq = psd_factor(Q, "observability");
    Q.resize(0, 0);
    const Mat          M = g->Lq.transpose() * g->Lp;
    const Eigen::Index k = std::min(M.rows(), M.cols());
    log("balanced truncation: singular values of the " + std::to_string(M.rows()) + " x " +
        std::to_string(M.cols()) + " product of the factors");
    if (o.order > k)
      throw InputError("balanced truncation: only " + std::to_string(k) + " states are both reached "
                       "by the inputs and seen by the outputs (to round-off); lower --order");
    // Every singular value where the exact SVD is affordable (the truncation's error bound
    // needs all), else the leading ones.
    g->complete  = k <= 4000;
    g->svd       = realization::leading_svd(M, g->complete ? static_cast<unsigned>(k) : o.order);
    g->tail_energy = std::max(0.0, M.squaredNorm() - g->svd.sigma.squaredNorm());
    g->seconds   = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return g;
  }

  StateSpaceModel
  realize_balanced(const ImpulseResponseModel &m, const BalancedGramians &g, const unsigned r)
  {
    const auto t0 = std::chrono::steady_clock::now();
    if (r == 0 || r > g.options.order)
      throw InputError("balanced truncation: order " + std::to_string(r) + " is not within 1 .. " +
                       std::to_string(g.options.order) + ", the order prepared for");
    const Vec &sigma = g.svd.sigma;
    if (!(sigma[r - 1] > 1e-14 * sigma[0]))
      throw InputError("balanced truncation: the realization has fewer than " + std::to_string(r) +
                       " states that matter (Hankel singular value " + std::to_string(r) +
                       " is zero to round-off); lower --order");
    const unsigned N = g.n_modes, nin = m.n_inputs, nout = m.n_outputs;
    const Vec      isq = sigma.head(r).cwiseSqrt().cwiseInverse();
    const Mat      T   = g.Lp * g.svd.V.leftCols(r) * isq.asDiagonal();             // n x r
    const Mat      Ti  = isq.asDiagonal() * g.svd.U.leftCols(r).transpose() * g.Lq.transpose(); // r x n
    Mat AT(3 * N, r), B(3 * N, nin), Tu(N, r);
    for (unsigned i = 0; i < N; ++i)
      {
        AT.middleRows(3 * i, 3) = g.A[i] * T.middleRows(3 * i, 3);
        B.middleRows(3 * i, 3)  = g.beta[i] * g.load_in.col(i).transpose();
        Tu.row(i)               = T.row(3 * i);
      }
    StateSpaceModel out;
    static_cast<ModelFrame &>(out) = m;
    out.method                     = "balanced_truncation";
    out.input_directions           = nin;
    out.stability_radius           = g.options.stability_radius;
    out.hankel_singular_values.assign(sigma.data(), sigma.data() + sigma.size());
    out.singular_values_complete = g.complete;
    realization::set_block_diagonal(out, Ti * AT, Ti * B, g.phi_out * Tu, g.options.stability_radius);
    out.output_dimension = nout;
    out.contact_direction.resize(nin);
    std::vector<char> contact(nout, 0);
    for (unsigned k = 0; k < nin; ++k)
      contact[out.contact_direction[k] = 3 * m.input_output_index[k / 3] + k % 3] = 1;
    out.output_directions =
      nout - static_cast<unsigned>(std::count(contact.begin(), contact.end(), 1));
    // D = H[0]: from H, or from the modes, q_i[0] = b_new's displacement.
    if (m.modal_only)
      {
        out.d.resize(static_cast<size_t>(nin) * nout);
        Vec q0(N);
        for (unsigned i = 0; i < N; ++i)
          q0[i] = m.modes.step[15 * static_cast<size_t>(i) + 3];
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          out.d.data(), nin, nout) = g.load_in * q0.asDiagonal() * g.phi_out.transpose();
      }
    else
      realization::set_feedthrough_from_h(out, m);
    out.identification_seconds =
      g.seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  StateSpaceModel
  balanced_truncation(const ImpulseResponseModel &m, const BalancedOptions &o)
  {
    return realize_balanced(m, *prepare_balanced(m, o), o.order);
  }
} // namespace irdm
