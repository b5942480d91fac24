// ElasticDynamics::lowest_modes: the lowest modes of the fixed system for models beyond the
// dense route, and the static compliance at the model's DoFs from the same factorization.
//
// Why SLEPc: it is the eigensolver deal.II is built with here, it shares PETSc's MUMPS
// (a Cholesky about 9x faster per solve than UMFPACK on this machine class, shared/notes), and
// Krylov-Schur with shift-invert at 0 finds the lowest modes of K phi = w^2 M phi in a few
// restarts. The static compliance then costs only triangular solves with the factors of K
// that the shift-invert already made (the shift is 0).
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

#include "elastodynamics_impl.h"

#include <slepceps.h>

#include <Eigen/Dense>

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
        throw std::runtime_error(std::string("SLEPc/PETSc: ") + what + " failed (error " +
                                 std::to_string(error) + ")");
    }

    // A sequential PETSc AIJ matrix of A restricted to the free DoFs (owned; destroyed with
    // the object).
    struct FreeMatrix
    {
      Mat mat = nullptr;
      FreeMatrix(const SparseMatrix<double> &A, const std::vector<int> &free_of_dof,
                 const PetscInt n_free)
      {
        std::vector<PetscInt> nnz(n_free, 0);
        for (unsigned row = 0; row < A.m(); ++row)
          if (free_of_dof[row] >= 0)
            for (auto it = A.begin(row); it != A.end(row); ++it)
              nnz[free_of_dof[row]] += free_of_dof[it->column()] >= 0;
        check(MatCreateSeqAIJ(PETSC_COMM_SELF, n_free, n_free, 0, nnz.data(), &mat),
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
              if (free_of_dof[it->column()] >= 0)
                {
                  cols.push_back(free_of_dof[it->column()]);
                  vals.push_back(it->value());
                }
            check(MatSetValues(mat, 1, &r, static_cast<PetscInt>(cols.size()), cols.data(),
                               vals.data(), INSERT_VALUES),
                  "MatSetValues");
          }
        check(MatAssemblyBegin(mat, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
        check(MatAssemblyEnd(mat, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
        check(MatSetOption(mat, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
      }
      ~FreeMatrix()
      {
        MatDestroy(&mat);
      }
      FreeMatrix(const FreeMatrix &) = delete;
      FreeMatrix &
      operator=(const FreeMatrix &) = delete;
    };

    struct Eps
    {
      EPS eps = nullptr;
      Eps()
      {
        check(EPSCreate(PETSC_COMM_SELF, &eps), "EPSCreate");
      }
      ~Eps()
      {
        EPSDestroy(&eps);
      }
      Eps(const Eps &) = delete;
      Eps &
      operator=(const Eps &) = delete;
    };

    struct SeqVec
    {
      Vec v = nullptr;
      explicit SeqVec(const PetscInt n)
      {
        check(VecCreateSeq(PETSC_COMM_SELF, n, &v), "VecCreateSeq");
      }
      ~SeqVec()
      {
        VecDestroy(&v);
      }
      SeqVec(const SeqVec &) = delete;
      SeqVec &
      operator=(const SeqVec &) = delete;
    };

    struct OwnedMat
    {
      Mat mat = nullptr;
      OwnedMat() = default;
      ~OwnedMat()
      {
        MatDestroy(&mat);
      }
      OwnedMat(const OwnedMat &) = delete;
      OwnedMat &
      operator=(const OwnedMat &) = delete;
    };

    struct OwnedKsp
    {
      KSP ksp = nullptr;
      OwnedKsp() = default;
      ~OwnedKsp()
      {
        KSPDestroy(&ksp);
      }
      OwnedKsp(const OwnedKsp &) = delete;
      OwnedKsp &
      operator=(const OwnedKsp &) = delete;
    };

    struct DenseMat
    {
      Mat mat = nullptr;
      DenseMat(const PetscInt rows, const PetscInt cols)
      {
        check(MatCreateSeqDense(PETSC_COMM_SELF, rows, cols, nullptr, &mat), "MatCreateSeqDense");
      }
      ~DenseMat()
      {
        MatDestroy(&mat);
      }
      DenseMat(const DenseMat &) = delete;
      DenseMat &
      operator=(const DenseMat &) = delete;
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
  } // namespace

  LowestModes
  ElasticDynamics::lowest_modes(const unsigned count, const std::vector<int> &rows,
                                const std::vector<int> &columns, const double step_shift,
                                const double tolerance) const
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

    auto             t0 = Clock::now();
    const FreeMatrix K(m.stiffness, free_of_dof, n), M(m.mass, free_of_dof, n);
    // The free body's shift eps: 1e-9 of the largest diagonal ratio K_ii / M_ii (about the
    // highest w2), so that K + eps M is factored with a condition number near 1e9 while eps is
    // far below the first elastic w2 (the refinement below then converges in a few passes).
    double rigid_shift = 0;
    if (free_body)
      {
        SeqVec kd(n), md(n);
        check(MatGetDiagonal(K.mat, kd.v), "MatGetDiagonal");
        check(MatGetDiagonal(M.mat, md.v), "MatGetDiagonal");
        const PetscScalar *pk, *pm;
        check(VecGetArrayRead(kd.v, &pk), "VecGetArrayRead");
        check(VecGetArrayRead(md.v, &pm), "VecGetArrayRead");
        for (PetscInt i = 0; i < n; ++i)
          rigid_shift = std::max(rigid_shift, pk[i] / pm[i]);
        check(VecRestoreArrayRead(kd.v, &pk), "VecRestoreArrayRead");
        check(VecRestoreArrayRead(md.v, &pm), "VecRestoreArrayRead");
        rigid_shift *= 1e-9;
        if (!(rigid_shift > 0))
          throw InputError("modes: the free body's stiffness has no positive diagonal");
      }
    const unsigned n_eigen = count + n_rigid;
    Eps              e;
    check(EPSSetOperators(e.eps, K.mat, M.mat), "EPSSetOperators");
    check(EPSSetProblemType(e.eps, EPS_GHEP), "EPSSetProblemType");
    check(EPSSetType(e.eps, EPSKRYLOVSCHUR), "EPSSetType");
    check(EPSSetDimensions(e.eps, n_eigen, PETSC_DEFAULT, PETSC_DEFAULT), "EPSSetDimensions");
    check(EPSSetWhichEigenpairs(e.eps, EPS_TARGET_MAGNITUDE), "EPSSetWhichEigenpairs");
    check(EPSSetTarget(e.eps, -rigid_shift), "EPSSetTarget");
    check(EPSSetTolerances(e.eps, tolerance, 1000), "EPSSetTolerances");
    ST  st;
    KSP ksp;
    PC  pc;
    check(EPSGetST(e.eps, &st), "EPSGetST");
    check(STSetType(st, STSINVERT), "STSetType");
    check(STGetKSP(st, &ksp), "STGetKSP");
    check(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
    check(KSPGetPC(ksp, &pc), "KSPGetPC");
    check(PCSetType(pc, PCCHOLESKY), "PCSetType");
    check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
    // SLEPc's purification (one more inverse iteration on each eigenvector) is done below as
    // one block solve, not one single-vector solve per mode (memory-bound: 30 of 140 s on
    // cat_fine P2).
    check(EPSSetPurify(e.eps, PETSC_FALSE), "EPSSetPurify");
    // PETSc options (PETSC_OPTIONS="-eps_ncv 300 ...") may tune the solver further.
    check(EPSSetFromOptions(e.eps), "EPSSetFromOptions");
    check(EPSSolve(e.eps), "EPSSolve");
    PetscInt converged = 0, iterations = 0;
    check(EPSGetConverged(e.eps, &converged), "EPSGetConverged");
    check(EPSGetIterationNumber(e.eps, &iterations), "EPSGetIterationNumber");
    if (converged < static_cast<PetscInt>(n_eigen))
      throw std::runtime_error("SLEPc converged " + std::to_string(converged) + " of " +
                               std::to_string(n_eigen) + " modes in " +
                               std::to_string(iterations) + " restarts");

    LowestModes out;
    out.n_lowest    = count;
    out.n_rigid     = n_rigid;
    out.rigid_shift = rigid_shift;
    out.iterations  = static_cast<unsigned>(iterations);
    const size_t nn = static_cast<size_t>(n), nc = columns.size();
    // Full-length vectors: the lowest modes (n x count) and the static responses (n x nc).
    const size_t n_aug = step_shift > 0 ? 2 * nc : nc; // residual vectors
    check_memory_estimate("the sparse modal route's vectors",
                          8.0 * nn * (2.0 * n_eigen + 3.0 * n_aug), false);
    // All eigenvectors found (the rigid ones first), then split below.
    Eigen::MatrixXd eigenvectors(n, n_eigen);
    std::vector<double> lambdas(n_eigen);
    SeqVec x(n); // an eigenvector as SLEPc gives it
    // F^-1 B for a Cholesky factor F and dense right-hand sides B (MUMPS's multiple-RHS solve).
    const auto solve = [&](const Mat factor, const Eigen::MatrixXd &rhs) {
      const PetscInt nb = static_cast<PetscInt>(rhs.cols());
      DenseMat       B(n, nb), Y(n, nb);
      PetscScalar    *b;
      PetscInt        ldb = n;
      check(MatDenseGetLDA(B.mat, &ldb), "MatDenseGetLDA");
      check(MatDenseGetArrayWrite(B.mat, &b), "MatDenseGetArrayWrite");
      for (PetscInt j = 0; j < nb; ++j)
        std::copy(rhs.col(j).data(), rhs.col(j).data() + n, b + j * ldb);
      check(MatDenseRestoreArrayWrite(B.mat, &b), "MatDenseRestoreArrayWrite");
      check(MatMatSolve(factor, B.mat, Y.mat), "MatMatSolve");
      return columns_of(Y.mat, n, nb);
    };
    // Unit loads at columns [c0, c0 + nb).
    const auto unit_loads = [&](const size_t c0, const size_t nb) {
      Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(nb));
      for (size_t j = 0; j < nb; ++j)
        E(columns[c0 + j], static_cast<Eigen::Index>(j)) = 1.0;
      return E;
    };
    const size_t block = 64; // columns per solve

    // A V for all columns of V at once: PETSc's sparse x dense product reads A once per few
    // columns, where one MatMult per column reads it once per column (both bound by memory).
    const auto apply = [&](const Mat A, const Eigen::MatrixXd &V) {
      const PetscInt nb = static_cast<PetscInt>(V.cols());
      if (nb == 0)
        return Eigen::MatrixXd(n, 0);
      OwnedMat v, av; // v wraps V's storage (column-major, leading dimension n): A V reads it
      check(MatCreateSeqDense(PETSC_COMM_SELF, n, nb, const_cast<PetscScalar *>(V.data()), &v.mat),
            "MatCreateSeqDense");
      check(MatMatMult(A, v.mat, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &av.mat), "MatMatMult");
      return columns_of(av.mat, n, nb);
    };
    for (unsigned i = 0; i < n_eigen; ++i)
      {
        PetscScalar lambda = 0;
        check(EPSGetEigenpair(e.eps, i, &lambda, nullptr, x.v, nullptr), "EPSGetEigenpair");
        if (i >= n_rigid && !(lambda > 0))
          throw std::runtime_error("the fixed system has a non-positive eigenvalue");
        if (i > n_rigid && lambda < lambdas[i - 1])
          throw std::runtime_error("SLEPc returned the modes out of order");
        lambdas[i] = lambda;
        const PetscScalar *p;
        check(VecGetArrayRead(x.v, &p), "VecGetArrayRead");
        std::copy(p, p + n, eigenvectors.col(i).data());
        check(VecRestoreArrayRead(x.v, &p), "VecRestoreArrayRead");
      }
    // Purification: x <- (K - s M)^-1 M x on the shift-invert's own factors, a block at a
    // time (one more step of inverse iteration: it takes out what the Krylov basis left of
    // the modes far from the shift). Then each is M-normalized (the sign is free: H uses
    // phi phi^T) and its relative residual |K x - w2 M x| / |K x| measured.
    Mat factor;
    check(PCFactorGetMatrix(pc, &factor), "PCFactorGetMatrix");
    for (size_t c0 = 0; c0 < n_eigen; c0 += block)
      {
        const auto nb   = static_cast<Eigen::Index>(std::min<size_t>(block, n_eigen - c0));
        auto       cols = eigenvectors.middleCols(static_cast<Eigen::Index>(c0), nb);
        cols            = solve(factor, apply(M.mat, cols));
        Eigen::MatrixXd mv = apply(M.mat, cols);
        for (Eigen::Index j = 0; j < nb; ++j)
          {
            const double scale = 1 / std::sqrt(cols.col(j).dot(mv.col(j)));
            cols.col(j) *= scale;
            mv.col(j) *= scale;
          }
        const Eigen::MatrixXd kv = apply(K.mat, cols);
        for (Eigen::Index j = 0; j < nb; ++j)
          {
            const size_t i = c0 + static_cast<size_t>(j);
            if (i >= n_rigid) // a rigid mode's K x is round-off: its residual means nothing
              out.largest_residual =
                std::max(out.largest_residual,
                         (kv.col(j) - lambdas[i] * mv.col(j)).norm() / kv.col(j).norm());
          }
      }
    // A free body: the six lowest must be rigid modes, |w2| at round-off against the first
    // elastic one (else the mesh is not one connected body, or something holds it).
    for (unsigned i = 0; i < n_rigid; ++i)
      out.rigid_w2_max = std::max(out.rigid_w2_max, std::abs(lambdas[i]));
    if (free_body && !(out.rigid_w2_max < 1e-6 * lambdas[n_rigid]))
      throw InputError("modes: the free body's six lowest eigenvalues are not rigid modes "
                       "(largest |w^2| " + std::to_string(out.rigid_w2_max) +
                       " against the next, " + std::to_string(lambdas[n_rigid]) +
                       "): is the mesh one connected body?");
    const Eigen::MatrixXd phi = eigenvectors.rightCols(count);
    const std::vector<double> w2(lambdas.begin() + n_rigid, lambdas.end());
    out.seconds_eigen = std::chrono::duration<double>(Clock::now() - t0).count();

    // The free body's rigid modes, M-orthonormal (SLEPc's are, to its tolerance; made so to
    // round-off here), and P V = V - Phi_r Phi_r^T M V, the M-orthogonal projection off them.
    Eigen::MatrixXd rigid = eigenvectors.leftCols(n_rigid);
    if (free_body)
      {
        Eigen::MatrixXd G = rigid.transpose() * apply(M.mat, rigid);
        G                 = 0.5 * (G + G.transpose()).eval();
        const Eigen::LLT<Eigen::MatrixXd> llt(G);
        if (llt.info() != Eigen::Success)
          throw std::runtime_error("the free body's rigid modes are not independent");
        rigid = llt.matrixU().solve<Eigen::OnTheRight>(rigid); // rigid U^-1: M-orthonormal
      }
    const Eigen::MatrixXd m_rigid = apply(M.mat, rigid);
    const auto            off_rigid = [&](Eigen::MatrixXd V) {
      for (int twice = 0; twice < (free_body ? 2 : 0); ++twice)
        V -= rigid * (m_rigid.transpose() * V);
      return V;
    };

    // Static responses at the columns: K^-1 E (the ST's factors are those of K, shift 0), or
    // for a free body the inertia-relief K^+ (I - M Phi_r Phi_r^T) E by refinement on the
    // factors of K + eps M (see the top of this file).
    t0 = Clock::now();
    Eigen::MatrixXd X(n, static_cast<Eigen::Index>(nc));
    for (size_t c0 = 0; c0 < nc; c0 += block)
      {
        const size_t    nb = std::min(block, nc - c0);
        Eigen::MatrixXd f  = unit_loads(c0, nb);
        if (free_body)
          f -= m_rigid * (rigid.transpose() * f); // the load less its rigid share
        Eigen::MatrixXd y = off_rigid(solve(factor, f));
        // Refine until the correction reaches round-off: it stops shrinking (by half a pass)
        // or falls below 1e-15 of the solution.
        double previous = 1e300;
        for (unsigned pass = 1; free_body; ++pass)
          {
            const Eigen::MatrixXd dy = off_rigid(solve(factor, f - apply(K.mat, y)));
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
    out.compliance.assign(rows.size() * nc, 0.0);
    for (size_t r = 0; r < rows.size(); ++r)
      for (size_t j = 0; j < nc; ++j)
        out.compliance[r * nc + j] = X(rows[r], j);

    // An M-orthonormal basis of what the columns of V add to span(phi, prior): each column
    // M-normalized, phi and prior projected out (twice is enough, Kahan), then the Gram
    // matrix's eigenvectors scaled, dropping directions below 1e-12 of the largest (the basis
    // already spans them). Twice through, so that nearly dependent columns still give a basis
    // orthonormal to round-off (the Rayleigh-Ritz below relies on it).
    const auto m_orthonormal = [&](Eigen::MatrixXd V, const Eigen::MatrixXd &prior) {
      const Eigen::MatrixXd mv = apply(M.mat, V);
      for (Eigen::Index j = 0; j < V.cols(); ++j)
        V.col(j) /= std::sqrt(V.col(j).dot(mv.col(j)));
      for (int pass = 0; pass < 2; ++pass)
        {
          for (int twice = 0; twice < 2; ++twice)
            {
              V -= phi * (phi.transpose() * apply(M.mat, V));
              V = off_rigid(V);
              if (prior.cols() > 0)
                V -= prior * (prior.transpose() * apply(M.mat, V));
            }
          Eigen::MatrixXd Mr = V.transpose() * apply(M.mat, V);
          Mr = 0.5 * (Mr + Mr.transpose()).eval();
          Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> mass_eigen(Mr);
          const double    d_max = mass_eigen.eigenvalues().maxCoeff();
          Eigen::MatrixXd B(V.cols(), 0);
          for (Eigen::Index j = 0; j < V.cols(); ++j)
            if (mass_eigen.eigenvalues()(j) > (pass == 0 ? 1e-12 * d_max : 0.5))
              {
                B.conservativeResize(Eigen::NoChange, B.cols() + 1);
                B.col(B.cols() - 1) =
                  mass_eigen.eigenvectors().col(j) / std::sqrt(mass_eigen.eigenvalues()(j));
              }
          V = (V * B).eval();
        }
      return V;
    };
    // Residual vectors (modal truncation augmentation): first what the static responses add
    // to the lowest modes, then what the one-step responses add to both.
    Eigen::MatrixXd psi = m_orthonormal(X, Eigen::MatrixXd(n, 0));
    if (step_shift > 0)
      {
        // One-step responses (K + sigma M)^-1 E_columns: a step of the FEM's integrator solves
        // with K_eff = a (K + sigma M) (Rayleigh damping), so with these in the basis the
        // feed-through H[0] at the inputs is exact too, not only the static compliance. The
        // force of a probe that prescribes a displacement is H[0]^-1 times it: it needs H[0].
        OwnedMat shifted;
        check(MatDuplicate(K.mat, MAT_COPY_VALUES, &shifted.mat), "MatDuplicate");
        check(MatAXPY(shifted.mat, step_shift, M.mat, DIFFERENT_NONZERO_PATTERN), "MatAXPY");
        check(MatSetOption(shifted.mat, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
        OwnedKsp step;
        check(KSPCreate(PETSC_COMM_SELF, &step.ksp), "KSPCreate");
        check(KSPSetOperators(step.ksp, shifted.mat, shifted.mat), "KSPSetOperators");
        check(KSPSetType(step.ksp, KSPPREONLY), "KSPSetType");
        PC step_pc;
        check(KSPGetPC(step.ksp, &step_pc), "KSPGetPC");
        check(PCSetType(step_pc, PCCHOLESKY), "PCSetType");
        check(PCFactorSetMatSolverType(step_pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
        check(KSPSetUp(step.ksp), "KSPSetUp");
        Mat step_factor;
        check(PCFactorGetMatrix(step_pc, &step_factor), "PCFactorGetMatrix");
        Eigen::MatrixXd step_responses(n, static_cast<Eigen::Index>(nc));
        for (size_t c0 = 0; c0 < nc; c0 += block)
          {
            const size_t nb = std::min(block, nc - c0);
            step_responses.middleCols(static_cast<Eigen::Index>(c0), static_cast<Eigen::Index>(nb)) =
              solve(step_factor, unit_loads(c0, nb));
          }
        const Eigen::MatrixXd step_basis = m_orthonormal(step_responses, psi);
        psi.conservativeResize(Eigen::NoChange, psi.cols() + step_basis.cols());
        psi.rightCols(step_basis.cols()) = step_basis;
      }
    // Rayleigh-Ritz on span(psi) (M-orthonormal): Kr y = w2 y gives the residual modes psi y,
    // K- and M-orthogonal to each other and to the lowest modes.
    Eigen::MatrixXd Kr = psi.transpose() * apply(K.mat, psi);
    Kr = 0.5 * (Kr + Kr.transpose()).eval();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ritz(Kr);
    const Eigen::MatrixXd Y = ritz.eigenvectors();
    const unsigned        nr = static_cast<unsigned>(Y.cols());
    const unsigned        total = count + nr;
    out.w2 = w2;
    out.w2.resize(total);
    out.shapes.assign(rows.size() * total, 0.0);
    Eigen::MatrixXd psi_rows(rows.size(), psi.cols());
    for (size_t r = 0; r < rows.size(); ++r)
      {
        for (unsigned i = 0; i < count; ++i)
          out.shapes[r * total + i] = phi(rows[r], i);
        psi_rows.row(r) = psi.row(rows[r]);
      }
    const Eigen::MatrixXd residual_rows = psi_rows * Y;
    for (unsigned i = 0; i < nr; ++i)
      {
        if (!(ritz.eigenvalues()(i) > 0))
          throw std::runtime_error("a residual mode has a non-positive eigenvalue");
        out.w2[count + i] = ritz.eigenvalues()(i);
        for (size_t r = 0; r < rows.size(); ++r)
          out.shapes[r * total + count + i] = residual_rows(r, i);
      }
    // Ascending over both kinds (a model's modes are stored in ascending frequency).
    std::vector<unsigned> order(total);
    for (unsigned i = 0; i < total; ++i)
      order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](unsigned a, unsigned b) { return out.w2[a] < out.w2[b]; });
    LowestModes sorted = out;
    for (unsigned i = 0; i < total; ++i)
      {
        sorted.w2[i] = out.w2[order[i]];
        for (size_t r = 0; r < rows.size(); ++r)
          sorted.shapes[r * total + i] = out.shapes[r * total + order[i]];
      }
    sorted.seconds_static = std::chrono::duration<double>(Clock::now() - t0).count();
    return sorted;
  }
} // namespace irdm::fem
