// ElasticDynamics::lowest_modes: the lowest modes of the fixed system for models beyond the
// dense route, and the static compliance at the model's DoFs from the same factorization.
//
// The eigensolver: shift-invert block Lanczos (block_lanczos.h) on MUMPS Cholesky factors
// through PETSc (about 9x faster per solve than UMFPACK on this machine class, shared/notes).
// The solves are bound by memory bandwidth, and a block of 16 right-hand sides reads the
// factor as often as one, so the block method beat SLEPc's single-vector Krylov-Schur, used
// here before (reports/scaling/sparse_route.md). The shift is 0 for a grounded body, so the
// static compliance then costs only triangular solves with the same factors.
//
// A free body (no fixed surface): K is singular (six rigid-body modes), so the shift-invert
// targets a small negative shift -eps (K + eps M is positive definite) and the six lowest
// eigenpairs, zero to round-off, are the rigid modes Phi_r, which every other vector is made
// M-orthogonal to. The static responses take the inertia-relief form: a unit load less its
// rigid share, f = (I - M Phi_r Phi_r^T) e (self-equilibrated), and y = K^+ f the solution of
// K y = f that is M-orthogonal to Phi_r (Craig and Kurdila, Fundamentals of Structural
// Dynamics, on inertia relief). It is reached from the factors of K + eps M by iterative
// refinement, y <- P (y + (K + eps M)^-1 (f - K y)) with P the M-orthogonal projector off
// Phi_r, which contracts each elastic mode's error by eps / (w2 + eps) per pass.
#include <irdm_common/error.h>
#include <irdm_common/files.h>

#include "dense_products.h"
#include "elastodynamics_impl.h"
#include "frame_couplings.h"

#include <reference_fem/block_lanczos.h>

#include <petscksp.h>

#include <Eigen/Dense>

#include <utility>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace irdm::fem
{
  namespace
  {
    void
    check(const PetscErrorCode error, const char *what)
    {
      if (error != 0)
        throw std::runtime_error(std::string("PETSc: ") + what + " failed (error " +
                                 std::to_string(error) + ")");
    }

    // Owns one PETSc object (created into &h) and destroys it with `destroy`; converts to
    // the handle, so that it passes where PETSc takes one.
    template <typename Handle, PetscErrorCode (*destroy)(Handle *)>
    struct Owned
    {
      Handle h = nullptr;
      Owned()  = default;
      Owned(Owned &&o) noexcept
        : h(o.h)
      {
        o.h = nullptr;
      }
      ~Owned()
      {
        destroy(&h);
      }
      Owned(const Owned &) = delete;
      Owned &
      operator=(const Owned &) = delete;
      Owned &
      operator=(Owned &&) = delete;
      operator Handle() const
      {
        return h;
      }
    };
    using OwnedMat = Owned<Mat, MatDestroy>;
    using OwnedVec = Owned<Vec, VecDestroy>;
    using OwnedKsp = Owned<KSP, KSPDestroy>;

    // A sequential PETSc AIJ matrix of A restricted to the free DoFs. With drop_zeros,
    // entries that are exactly zero are left out: the vector mass matrix couples no two
    // components, so two thirds of its pattern are such zeros, and every product with it
    // would read them.
    OwnedMat
    free_matrix(const SparseMatrix<double> &A, const std::vector<int> &free_of_dof,
                const PetscInt n_free, const bool drop_zeros)
    {
      OwnedMat              out;
      std::vector<PetscInt> nnz(n_free, 0);
      for (unsigned row = 0; row < A.m(); ++row)
        if (free_of_dof[row] >= 0)
          for (auto it = A.begin(row); it != A.end(row); ++it)
            nnz[free_of_dof[row]] +=
              free_of_dof[it->column()] >= 0 && (!drop_zeros || it->value() != 0);
      check(MatCreateSeqAIJ(PETSC_COMM_SELF, n_free, n_free, 0, nnz.data(), &out.h),
            "MatCreateSeqAIJ");
      std::vector<PetscInt>    cols;
      std::vector<PetscScalar> vals;
      for (unsigned row = 0; row < A.m(); ++row)
        {
          const PetscInt r = free_of_dof[row];
          if (r < 0)
            continue;
          cols.clear();
          vals.clear();
          for (auto it = A.begin(row); it != A.end(row); ++it)
            if (free_of_dof[it->column()] >= 0 && (!drop_zeros || it->value() != 0))
              {
                cols.push_back(free_of_dof[it->column()]);
                vals.push_back(it->value());
              }
          check(MatSetValues(out, 1, &r, static_cast<PetscInt>(cols.size()), cols.data(),
                             vals.data(), INSERT_VALUES),
                "MatSetValues");
        }
      check(MatAssemblyBegin(out, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
      check(MatAssemblyEnd(out, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
      check(MatSetOption(out, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
      return out;
    }

    // A sequential dense rows x cols matrix (PETSc's storage, zero).
    OwnedMat
    dense_matrix(const PetscInt rows, const PetscInt cols)
    {
      OwnedMat out;
      check(MatCreateSeqDense(PETSC_COMM_SELF, rows, cols, nullptr, &out.h), "MatCreateSeqDense");
      return out;
    }

    // A sequential MUMPS Cholesky factorization of the symmetric A, kept with its solver.
    struct Cholesky
    {
      OwnedKsp ksp;
      Mat      factor = nullptr; // owned by ksp
      explicit Cholesky(const Mat A)
      {
        check(KSPCreate(PETSC_COMM_SELF, &ksp.h), "KSPCreate");
        check(KSPSetOperators(ksp, A, A), "KSPSetOperators");
        check(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
        PC pc;
        check(KSPGetPC(ksp, &pc), "KSPGetPC");
        check(PCSetType(pc, PCCHOLESKY), "PCSetType");
        check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
        check(KSPSetUp(ksp), "KSPSetUp");
        check(PCFactorGetMatrix(pc, &factor), "PCFactorGetMatrix");
      }
      // The factors again after A's values changed in place (its pattern unchanged: PETSc
      // then repeats only MUMPS's numerical factorization).
      Mat
      refactor()
      {
        Mat A = nullptr;
        check(KSPGetOperators(ksp, &A, nullptr), "KSPGetOperators");
        check(KSPSetOperators(ksp, A, A), "KSPSetOperators");
        check(KSPSetUp(ksp), "KSPSetUp");
        PC pc;
        check(KSPGetPC(ksp, &pc), "KSPGetPC");
        check(PCFactorGetMatrix(pc, &factor), "PCFactorGetMatrix");
        return factor;
      }
    };

    // The first `cols` columns of a sequential dense PETSc matrix with n rows.
    Eigen::MatrixXd
    columns_of(const Mat dense, const PetscInt n, const PetscInt cols)
    {
      Eigen::MatrixXd    X(n, cols);
      const PetscScalar *p;
      PetscInt           lda = n;
      check(MatDenseGetLDA(dense, &lda), "MatDenseGetLDA");
      check(MatDenseGetArrayRead(dense, &p), "MatDenseGetArrayRead");
      for (PetscInt j = 0; j < cols; ++j)
        std::copy(p + j * lda, p + j * lda + n, X.col(j).data());
      check(MatDenseRestoreArrayRead(dense, &p), "MatDenseRestoreArrayRead");
      return X;
    }

    // F^-1 B for a Cholesky factor F and dense right-hand sides B (MUMPS's multiple-RHS solve).
    Eigen::MatrixXd
    solve(const Mat factor, const Eigen::MatrixXd &rhs)
    {
      const auto     n  = static_cast<PetscInt>(rhs.rows());
      const PetscInt nb = static_cast<PetscInt>(rhs.cols());
      const OwnedMat B = dense_matrix(n, nb), Y = dense_matrix(n, nb);
      PetscScalar   *b;
      PetscInt       ldb = n;
      check(MatDenseGetLDA(B, &ldb), "MatDenseGetLDA");
      check(MatDenseGetArrayWrite(B, &b), "MatDenseGetArrayWrite");
      for (PetscInt j = 0; j < nb; ++j)
        std::copy(rhs.col(j).data(), rhs.col(j).data() + n, b + j * ldb);
      check(MatDenseRestoreArrayWrite(B, &b), "MatDenseRestoreArrayWrite");
      check(MatMatSolve(factor, B, Y), "MatMatSolve");
      return columns_of(Y, n, nb);
    }

    // Unit loads (n rows) at the free DoFs columns[c0, c0 + nb).
    Eigen::MatrixXd
    unit_loads(const PetscInt n, const std::vector<int> &columns, const size_t c0,
               const size_t nb)
    {
      Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(nb));
      for (size_t j = 0; j < nb; ++j)
        E(columns[c0 + j], static_cast<Eigen::Index>(j)) = 1.0;
      return E;
    }

    constexpr size_t block = 64; // columns per solve of the unit loads and vectors below

    // The one-step responses (K + sigma M)^-1 e_c at the columns, a block of unit loads per
    // solve; factor: the factorization of K + sigma M.
    Eigen::MatrixXd
    step_responses_of(const Mat factor, const PetscInt n, const std::vector<int> &columns)
    {
      const size_t    nc = columns.size();
      Eigen::MatrixXd out(n, static_cast<Eigen::Index>(nc));
      for (size_t c0 = 0; c0 < nc; c0 += block)
        {
          const size_t nb = std::min(block, nc - c0);
          out.middleCols(static_cast<Eigen::Index>(c0), static_cast<Eigen::Index>(nb)) =
            solve(factor, unit_loads(n, columns, c0, nb));
        }
      return out;
    }

    // The free DoFs' K and M as PETSc matrices, and products with them.
    struct FreeSystem
    {
      PetscInt n         = 0;
      bool     free_body = false; // nothing fixed: six rigid-body modes
      OwnedMat K, M;

      // A V for all columns of V at once: PETSc's sparse x dense product reads A once per few
      // columns, where one MatMult per column reads it once per column (both bound by memory).
      Eigen::MatrixXd
      apply(const Mat A, const ConstBlock &V) const
      {
        const PetscInt nb = static_cast<PetscInt>(V.cols());
        if (nb == 0)
          return Eigen::MatrixXd(n, 0);
        if (V.outerStride() != n)
          throw std::logic_error("apply: the columns must be contiguous");
        OwnedMat v, av; // v wraps V's storage (column-major, leading dimension n): A V reads it
        check(MatCreateSeqDense(PETSC_COMM_SELF, n, nb, const_cast<PetscScalar *>(V.data()), &v.h),
              "MatCreateSeqDense");
        check(MatMatMult(A, v, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &av.h), "MatMatMult");
        return columns_of(av, n, nb);
      }
      // The same for many columns, a block at a time into one result: a single product would
      // hold PETSc's result and its copy at once (two n x columns matrices, gigabytes for the
      // trace region's residual vectors on the fine cat).
      static constexpr Eigen::Index column_block = 256;
      Eigen::MatrixXd
      apply_blocked(const Mat A, const Eigen::MatrixXd &V) const
      {
        Eigen::MatrixXd AV(n, V.cols());
        for (Eigen::Index c0 = 0; c0 < V.cols(); c0 += column_block)
          {
            const Eigen::Index nb = std::min(column_block, V.cols() - c0);
            AV.middleCols(c0, nb) = apply(A, V.middleCols(c0, nb));
          }
        return AV;
      }
    };

    // The free body's shift eps: 1e-9 of the largest diagonal ratio K_ii / M_ii (about the
    // highest w2), so that K + eps M is factored with a condition number near 1e9 while eps is
    // far below the first elastic w2 (the refinement of the static responses then converges
    // in a few passes).
    double
    rigid_shift_of(const FreeSystem &sys)
    {
      OwnedVec kd, md;
      check(VecCreateSeq(PETSC_COMM_SELF, sys.n, &kd.h), "VecCreateSeq");
      check(VecCreateSeq(PETSC_COMM_SELF, sys.n, &md.h), "VecCreateSeq");
      check(MatGetDiagonal(sys.K, kd), "MatGetDiagonal");
      check(MatGetDiagonal(sys.M, md), "MatGetDiagonal");
      const PetscScalar *pk, *pm;
      double             shift = 0;
      check(VecGetArrayRead(kd, &pk), "VecGetArrayRead");
      check(VecGetArrayRead(md, &pm), "VecGetArrayRead");
      for (PetscInt i = 0; i < sys.n; ++i)
        shift = std::max(shift, pk[i] / pm[i]);
      check(VecRestoreArrayRead(kd, &pk), "VecRestoreArrayRead");
      check(VecRestoreArrayRead(md, &pm), "VecRestoreArrayRead");
      shift *= 1e-9;
      if (!(shift > 0))
        throw InputError("modes: the free body's stiffness has no positive diagonal");
      return shift;
    }

    // Every eigenpair found (the rigid ones first): the vectors, M times them, and w2.
    struct Eigenpairs
    {
      Eigen::MatrixXd     vectors, m_vectors;
      std::vector<double> w2;
    };

    // The Lanczos pairs as eigenpairs: w2 = 1 / theta - eps, each vector M-normalized (the
    // sign is free: H uses phi phi^T) and its relative residual |K x - w2 M x| / |K x|
    // measured into out, a block at a time; a free body's six lowest checked to be rigid.
    Eigenpairs
    normalized_eigenpairs(const FreeSystem &sys, LanczosPairs &pairs, LowestModes &out)
    {
      const auto n_eigen = static_cast<size_t>(pairs.theta.size());
      Eigenpairs e;
      // Purified (one more step of inverse iteration, from the Lanczos relation without a
      // solve: block_lanczos.h), which takes out what the random start block left of the
      // modes far from the shift.
      e.vectors = std::move(pairs.purified);
      e.m_vectors.resize(sys.n, static_cast<Eigen::Index>(n_eigen));
      e.w2.resize(n_eigen);
      for (size_t i = 0; i < n_eigen; ++i)
        {
          e.w2[i] = 1 / pairs.theta(static_cast<Eigen::Index>(i)) - out.rigid_shift;
          if (i >= out.n_rigid && !(e.w2[i] > 0))
            throw std::runtime_error("the fixed system has a non-positive eigenvalue");
        }
      for (size_t c0 = 0; c0 < n_eigen; c0 += block)
        {
          const auto nb   = static_cast<Eigen::Index>(std::min<size_t>(block, n_eigen - c0));
          auto       cols = e.vectors.middleCols(static_cast<Eigen::Index>(c0), nb);
          auto       mv   = e.m_vectors.middleCols(static_cast<Eigen::Index>(c0), nb);
          mv              = sys.apply(sys.M, cols);
          for (Eigen::Index j = 0; j < nb; ++j)
            {
              const double scale = 1 / std::sqrt(cols.col(j).dot(mv.col(j)));
              cols.col(j) *= scale;
              mv.col(j) *= scale;
            }
          const Eigen::MatrixXd kv = sys.apply(sys.K, cols);
          for (Eigen::Index j = 0; j < nb; ++j)
            {
              const size_t i = c0 + static_cast<size_t>(j);
              if (i >= out.n_rigid) // a rigid mode's K x is round-off: its residual means nothing
                out.largest_residual =
                  std::max(out.largest_residual,
                           (kv.col(j) - e.w2[i] * mv.col(j)).norm() / kv.col(j).norm());
            }
        }
      // A free body: the six lowest must be rigid modes, |w2| at round-off against the first
      // elastic one (else the mesh is not one connected body, or something holds it).
      for (unsigned i = 0; i < out.n_rigid; ++i)
        out.rigid_w2_max = std::max(out.rigid_w2_max, std::abs(e.w2[i]));
      if (sys.free_body && !(out.rigid_w2_max < 1e-6 * e.w2[out.n_rigid]))
        throw InputError("modes: the free body's six lowest eigenvalues are not rigid modes "
                         "(largest |w^2| " + std::to_string(out.rigid_w2_max) +
                         " against the next, " + std::to_string(e.w2[out.n_rigid]) +
                         "): is the mesh one connected body?");
      return e;
    }

    // The free body's rigid modes Phi_r, M-orthonormal (the Ritz vectors are, to the Lanczos
    // tolerance; made so to round-off here), and P V = V - Phi_r Phi_r^T M V, the M-orthogonal
    // projection off them. A grounded body has none: P is the identity.
    struct RigidProjector
    {
      Eigen::MatrixXd rigid, m_rigid;
      bool            on = false;

      RigidProjector(const FreeSystem &sys, const Eigenpairs &e, const unsigned n_rigid)
        : rigid(e.vectors.leftCols(n_rigid))
        , on(sys.free_body)
      {
        if (on)
          {
            Eigen::MatrixXd G = rigid.transpose() * sys.apply(sys.M, rigid);
            G                 = 0.5 * (G + G.transpose()).eval();
            const Eigen::LLT<Eigen::MatrixXd> llt(G);
            if (llt.info() != Eigen::Success)
              throw std::runtime_error("the free body's rigid modes are not independent");
            rigid = llt.matrixU().solve<Eigen::OnTheRight>(rigid); // rigid U^-1: M-orthonormal
          }
        m_rigid = sys.apply(sys.M, rigid);
      }
      Eigen::MatrixXd
      off(Eigen::MatrixXd V) const
      {
        for (int twice = 0; twice < (on ? 2 : 0); ++twice)
          V -= rigid * (m_rigid.transpose() * V);
        return V;
      }
    };

    // Static responses at the columns: K^-1 E (the factors are those of K, shift 0), or for
    // a free body the inertia-relief K^+ (I - M Phi_r Phi_r^T) E by refinement on the
    // factors of K + eps M (the top of this file), with its passes recorded in out.
    Eigen::MatrixXd
    static_responses(const FreeSystem &sys, const Mat factor, const RigidProjector &P,
                     const std::vector<int> &columns, LowestModes &out)
    {
      const size_t    nc = columns.size();
      Eigen::MatrixXd X(sys.n, static_cast<Eigen::Index>(nc));
      for (size_t c0 = 0; c0 < nc; c0 += block)
        {
          const size_t    nb = std::min(block, nc - c0);
          Eigen::MatrixXd f  = unit_loads(sys.n, columns, c0, nb);
          if (sys.free_body)
            f -= P.m_rigid * (P.rigid.transpose() * f); // the load less its rigid share
          Eigen::MatrixXd y = P.off(solve(factor, f));
          // Refine until the correction reaches round-off: it stops shrinking (by half a
          // pass) or falls below 1e-15 of the solution.
          double previous = 1e300;
          for (unsigned pass = 1; sys.free_body; ++pass)
            {
              const Eigen::MatrixXd dy = P.off(solve(factor, f - sys.apply(sys.K, y)));
              y += dy;
              const double change = dy.cwiseAbs().maxCoeff() / y.cwiseAbs().maxCoeff();
              if (change <= 1e-15 || change > 0.5 * previous || pass == 30)
                {
                  out.refinement_passes = std::max(out.refinement_passes, pass);
                  out.refinement_change = std::max(out.refinement_change, change);
                  break;
                }
              previous = change;
            }
          X.middleCols(static_cast<Eigen::Index>(c0), static_cast<Eigen::Index>(nb)) = y;
        }
      return X;
    }

    struct MassBasis
    {
      Eigen::MatrixXd V, MV; // M-orthonormal columns and M times them
    };

    // An M-orthonormal basis of what the columns of V add to span(phi, rigid, prior): each
    // column M-normalized, those projected out (twice is enough, Kahan), then the Gram
    // matrix's eigenvectors scaled, dropping directions below 1e-12 of the largest (the basis
    // already spans them). Twice through, so that nearly dependent columns still give a basis
    // orthonormal to round-off (the Rayleigh-Ritz of the residual modes relies on it).
    MassBasis
    m_orthonormal(const FreeSystem &sys, const Eigen::MatrixXd &phi, const Eigen::MatrixXd &m_phi,
                  const RigidProjector &P, Eigen::MatrixXd V, const MassBasis &prior)
    {
      if (V.cols() == 0) // no columns asked for (lowest modes alone)
        {
          MassBasis none;
          none.V  = Eigen::MatrixXd(V.rows(), 0);
          none.MV = Eigen::MatrixXd(V.rows(), 0);
          return none;
        }
      constexpr Eigen::Index column_block = FreeSystem::column_block;
      // Projections through the stored M phi and M prior: one product with M per pass.
      const auto project_off = [&](Eigen::MatrixXd &W) {
        subtract_product(phi, product(m_phi, true, W), W);
        W = P.off(W);
        subtract_product(prior.V, product(prior.MV, true, W), W);
      };
      for (Eigen::Index c0 = 0; c0 < V.cols(); c0 += column_block)
        {
          const Eigen::Index    nb = std::min(column_block, V.cols() - c0);
          const Eigen::MatrixXd mv = sys.apply(sys.M, V.middleCols(c0, nb));
          for (Eigen::Index j = 0; j < nb; ++j)
            V.col(c0 + j) /= std::sqrt(V.col(c0 + j).dot(mv.col(j)));
        }
      MassBasis out;
      for (int pass = 0; pass < 2; ++pass)
        {
          for (int twice = 0; twice < 2; ++twice)
            project_off(V);
          const Eigen::MatrixXd MV = sys.apply_blocked(sys.M, V);
          Eigen::MatrixXd       Mr = product(V, true, MV);
          Mr                       = 0.5 * (Mr + Mr.transpose()).eval();
          Eigen::VectorXd d; // Mr's eigenvalues; Mr then holds its eigenvectors
          symmetric_eigen(Mr, d);
          const double              d_max = d.maxCoeff();
          std::vector<Eigen::Index> kept;
          for (Eigen::Index j = 0; j < V.cols(); ++j)
            if (d(j) > (pass == 0 ? 1e-12 * d_max : 0.5))
              kept.push_back(j);
          Eigen::MatrixXd B(V.cols(), static_cast<Eigen::Index>(kept.size()));
          for (size_t c = 0; c < kept.size(); ++c)
            B.col(static_cast<Eigen::Index>(c)) = Mr.col(kept[c]) / std::sqrt(d(kept[c]));
          V      = product(V, false, B);
          out.MV = product(MV, false, B);
        }
      out.V = std::move(V);
      return out;
    }

    // Rayleigh-Ritz on span(psi) (M-orthonormal): Kr y = w2 y gives the residual modes psi y,
    // K- and M-orthogonal to each other and to the lowest modes. Their w2 and their shapes
    // at the rows are appended to out's (which holds the lowest modes').
    // Returns the Rayleigh-Ritz eigenvectors: residual mode i is psi times column i.
    Eigen::MatrixXd
    append_residual_modes(const FreeSystem &sys, const Eigen::MatrixXd &psi,
                          const std::vector<int> &rows, LowestModes &out)
    {
      constexpr Eigen::Index column_block = FreeSystem::column_block;
      Eigen::MatrixXd        Kr(psi.cols(), psi.cols());
      for (Eigen::Index c0 = 0; c0 < psi.cols(); c0 += column_block)
        {
          const Eigen::Index nb = std::min(column_block, psi.cols() - c0);
          Kr.middleCols(c0, nb) = product(psi, true, sys.apply(sys.K, psi.middleCols(c0, nb)));
        }
      Kr = 0.5 * (Kr + Kr.transpose()).eval();
      Eigen::VectorXd ritz_w2; // Kr's eigenvalues; Kr then holds its eigenvectors
      symmetric_eigen(Kr, ritz_w2);
      const unsigned count = out.n_lowest, nr = static_cast<unsigned>(Kr.cols());
      const unsigned total = count + nr;
      const std::vector<double> lowest = out.shapes;
      out.w2.resize(total);
      out.shapes.assign(rows.size() * total, 0.0);
      Eigen::MatrixXd psi_rows(rows.size(), psi.cols());
      for (size_t r = 0; r < rows.size(); ++r)
        {
          for (unsigned i = 0; i < count; ++i)
            out.shapes[r * total + i] = lowest[r * count + i];
          psi_rows.row(static_cast<Eigen::Index>(r)) = psi.row(rows[r]);
        }
      const Eigen::MatrixXd residual_rows = psi_rows * Kr;
      for (unsigned i = 0; i < nr; ++i)
        {
          if (!(ritz_w2(i) > 0))
            throw std::runtime_error("a residual mode has a non-positive eigenvalue");
          out.w2[count + i] = ritz_w2(i);
          for (size_t r = 0; r < rows.size(); ++r)
            out.shapes[r * total + count + i] = residual_rows(static_cast<Eigen::Index>(r), i);
        }
      return Kr;
    }

    // Ascending frequency over both kinds (a model's modes are stored so).
    std::vector<unsigned>
    frequency_order(const std::vector<double> &w2)
    {
      std::vector<unsigned> order(w2.size());
      for (unsigned i = 0; i < order.size(); ++i)
        order[i] = i;
      std::stable_sort(order.begin(), order.end(),
                       [&](unsigned a, unsigned b) { return w2[a] < w2[b]; });
      return order;
    }

    // A free body's frame couplings (frame_couplings.h) of the kept modes, the lowest (phi) and
    // the residual ones (psi ritz): every mode's centrifugal load, in out's order, and the
    // inertial couplings of the first n_inertial in frequency order. offset and axis: each
    // free DoF's support point less the centre of mass, and its axis.
    void
    add_frame_couplings(const FreeSystem &sys, const Eigen::MatrixXd &phi,
                        const Eigen::MatrixXd &psi, const Eigen::MatrixXd &ritz,
                        const std::vector<unsigned> &order, const std::vector<Vec3> &offset,
                        const std::vector<unsigned char> &axis, const unsigned n_inertial,
                        LowestModes &out)
    {
      const Eigen::MatrixXd MW = sys.apply(sys.M, frame_couplings::linear_fields(offset, axis));
      const auto            count = phi.cols(), total = count + ritz.cols();
      Eigen::MatrixXd       C(total, 9);
      C.topRows(count)                = phi.transpose() * MW;
      C.bottomRows(ritz.cols())       = ritz.transpose() * (psi.transpose() * MW);
      out.centrifugal.resize(static_cast<size_t>(total) * 9);
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>>(out.centrifugal.data(), total, 9) = C;
      out.n_inertial = std::min<unsigned>(n_inertial, static_cast<unsigned>(total));
      Eigen::MatrixXd V(sys.n, out.n_inertial); // the first modes in frequency order, whole
      for (unsigned k = 0; k < out.n_inertial; ++k)
        V.col(k) = order[k] < count ? Eigen::VectorXd(phi.col(order[k]))
                                    : Eigen::VectorXd(psi * ritz.col(order[k] - count));
      const Eigen::MatrixXd MV    = sys.apply_blocked(sys.M, V);
      const auto            nodes = frame_couplings::node_triples(offset, axis);
      std::array<Eigen::MatrixXd, 3> component, m_component;
      for (int a = 0; a < 3; ++a)
        component[a] = frame_couplings::component(V, nodes, a),
        m_component[a] = frame_couplings::component(MV, nodes, a);
      out.inertial = frame_couplings::inertial_blocks(component, m_component);
    }

    // Ascending over both kinds (a model's modes are stored in ascending frequency).
    LowestModes
    sorted_by_frequency(const LowestModes &out, const size_t n_rows, const std::vector<unsigned> &order)
    {
      const auto  total  = static_cast<unsigned>(out.w2.size());
      LowestModes sorted = out;
      for (unsigned i = 0; i < total; ++i)
        {
          sorted.w2[i] = out.w2[order[i]];
          for (size_t r = 0; r < n_rows; ++r)
            sorted.shapes[r * total + i] = out.shapes[r * total + order[i]];
          if (!out.centrifugal.empty())
            std::copy_n(&out.centrifugal[9 * static_cast<size_t>(order[i])], 9, &sorted.centrifugal[9 * static_cast<size_t>(i)]);
        }
      return sorted;
    }
  } // namespace

  LowestModes
  ElasticDynamics::lowest_modes(const unsigned count, const std::vector<int> &rows,
                                const std::vector<int> &columns, const double step_shift,
                                const unsigned inertial_modes, const double tolerance) const
  {
    using Clock = std::chrono::steady_clock;
    const Impl &m = *impl_;
    // Nothing fixed: a free body, whose six rigid-body modes come first and are left out.
    const bool             free_body   = m.constraints.n_constraints() == 0;
    const unsigned         n_rigid     = free_body ? 6 : 0;
    const std::vector<int> free_of_dof = m.free_of_dof();
    const PetscInt         n           = static_cast<PetscInt>(n_free_dofs());
    if (count < 1 || static_cast<PetscInt>(count + n_rigid) >= n)
      throw InputError("the sparse modal route keeps 1 to " + std::to_string(n - 1 - n_rigid) +
                       " modes of the " + std::to_string(n) + " free DoFs; " +
                       std::to_string(count) + " were asked");
    for (const int r : rows)
      if (r < 0 || r >= n)
        throw std::logic_error("lowest_modes: a row is not a free DoF");
    for (const int c : columns)
      if (c < 0 || c >= n)
        throw std::logic_error("lowest_modes: a column is not a free DoF");

    auto t0 = Clock::now();
    // K keeps its whole pattern, which holds M's: K + s M then has K's pattern for every s.
    const FreeSystem sys{n, free_body, free_matrix(m.stiffness, free_of_dof, n, false),
                         free_matrix(m.mass, free_of_dof, n, true)};
    const unsigned n_eigen = count + n_rigid;
    LowestModes    out;
    out.n_lowest    = count;
    out.n_rigid     = n_rigid;
    out.rigid_shift = sys.free_body ? rigid_shift_of(sys) : 0.0;
    const size_t nn = static_cast<size_t>(n), nc = columns.size();
    // Full-length vectors: the block Lanczos basis (and M times it), the lowest modes
    // (n x count) and the static responses (n x nc).
    // The block Lanczos's block: 16 and 32 took the same time on the fine cats (fewer solves
    // against a larger basis to orthogonalize); 16 needs the smaller basis. At least 6: a free
    // body's six rigid modes share one eigenvalue, and a block Krylov space finds at most a
    // block's worth of copies.
    const size_t lanczos_block = 16;
    const size_t n_aug = step_shift > 0 ? 2 * nc : nc; // residual vectors
    // The basis limit: 4 vectors per mode sufficed on the fine cats; a few modes need more
    // per mode (the coarse 2 kPa cat's lowest 20 did not converge in 184), hence at least 400.
    const size_t lanczos_basis = std::min<size_t>(nn, std::max<size_t>(6 * n_eigen + 4 * lanczos_block, 400));
    // The Lanczos basis (and M times it) is freed before the residual vectors are made; those
    // peak at about 3 n_aug vectors (the static ones and their M products, with the one-step
    // ones' basis being made).
    check_memory_estimate("the sparse modal route's vectors",
                          8.0 * nn * (std::max(2.0 * lanczos_basis, 3.0 * n_aug) + 2.0 * n_eigen),
                          false);

    // The lowest modes: block Lanczos on S = (K + eps M)^-1 M (K^-1 M for a grounded body),
    // whose largest eigenvalues theta = 1 / (w2 + eps) are the lowest w2. K + eps M is
    // factored here, and later, in place, K + sigma M at the step's shift: the same pattern,
    // so MUMPS's analysis (ordering and symbolic factorization) is done once.
    OwnedMat shifted_stiffness;
    check(MatDuplicate(sys.K, MAT_COPY_VALUES, &shifted_stiffness.h), "MatDuplicate");
    if (sys.free_body)
      check(MatAXPY(shifted_stiffness, out.rigid_shift, sys.M, SUBSET_NONZERO_PATTERN), "MatAXPY");
    check(MatSetOption(shifted_stiffness, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
    const auto factor_started = Clock::now();
    Cholesky   shift_invert(shifted_stiffness);
    out.seconds_factor = std::chrono::duration<double>(Clock::now() - factor_started).count();
    const Mat    factor = shift_invert.factor;
    LanczosPairs pairs  = block_lanczos(
      n, n_eigen, [&](const Eigen::MatrixXd &B) { return solve(factor, B); },
      [&](const Eigen::MatrixXd &V) { return sys.apply(sys.M, V); }, tolerance,
      static_cast<Eigen::Index>(lanczos_block), static_cast<Eigen::Index>(lanczos_basis));
    out.iterations      = pairs.block_solves;
    out.seconds_lanczos = pairs.seconds;
    out.seconds_solves  = pairs.seconds_solves;
    const Eigenpairs      eigen = normalized_eigenpairs(sys, pairs, out);
    const Eigen::MatrixXd phi   = eigen.vectors.rightCols(count);
    const Eigen::MatrixXd m_phi = eigen.m_vectors.rightCols(count);
    out.w2.assign(eigen.w2.begin() + n_rigid, eigen.w2.end());
    out.shapes.resize(rows.size() * count);
    for (size_t r = 0; r < rows.size(); ++r)
      for (unsigned i = 0; i < count; ++i)
        out.shapes[r * count + i] = phi(rows[r], i);
    out.seconds_eigen = std::chrono::duration<double>(Clock::now() - t0).count();

    t0 = Clock::now();
    const RigidProjector P(sys, eigen, n_rigid);
    Eigen::MatrixXd      X = static_responses(sys, factor, P, columns, out);
    out.compliance.assign(rows.size() * nc, 0.0);
    for (size_t r = 0; r < rows.size(); ++r)
      for (size_t j = 0; j < nc; ++j)
        out.compliance[r * nc + j] = X(rows[r], j);

    // Residual vectors (modal truncation augmentation): first what the static responses add
    // to the lowest modes, then what the one-step responses add to both.
    // X is not needed past here (its rows are in out.compliance): moved, not copied.
    MassBasis psi = m_orthonormal(sys, phi, m_phi, P, std::move(X),
                                  MassBasis{Eigen::MatrixXd(n, 0), Eigen::MatrixXd(n, 0)});
    if (step_shift > 0)
      {
        // One-step responses (K + sigma M)^-1 E_columns: a step of the FEM's integrator solves
        // with K_eff = a (K + sigma M) (Rayleigh damping), so with these in the basis the
        // feed-through H[0] at the inputs is exact too, not only the static compliance. The
        // force of a probe that prescribes a displacement is H[0]^-1 times it: it needs H[0].
        // K + sigma M factored in place of K + eps M (the same pattern: MUMPS's analysis is
        // reused).
        check(MatAXPY(shifted_stiffness, step_shift - out.rigid_shift, sys.M, SUBSET_NONZERO_PATTERN),
              "MatAXPY");
        const MassBasis step_basis = m_orthonormal(
          sys, phi, m_phi, P, step_responses_of(shift_invert.refactor(), n, columns), psi);
        psi.V.conservativeResize(Eigen::NoChange, psi.V.cols() + step_basis.V.cols());
        psi.V.rightCols(step_basis.V.cols()) = step_basis.V;
      }
    psi.MV = Eigen::MatrixXd(); // the Rayleigh-Ritz needs K psi, not M psi
    const Eigen::MatrixXd       ritz  = append_residual_modes(sys, psi.V, rows, out);
    const std::vector<unsigned> order = frequency_order(out.w2);
    if (free_body && inertial_modes > 0)
      {
        std::vector<Vec3>          offset;
        std::vector<unsigned char> axis;
        m.free_dof_geometry(offset, axis);
        add_frame_couplings(sys, phi, psi.V, ritz, order, offset, axis, inertial_modes, out);
      }
    LowestModes sorted    = sorted_by_frequency(out, rows.size(), order);
    sorted.seconds_static = std::chrono::duration<double>(Clock::now() - t0).count();
    return sorted;
  }
} // namespace irdm::fem
