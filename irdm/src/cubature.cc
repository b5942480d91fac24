// Training a reduced nonlinear model's cubature (irdm/cubature.h).
#include <irdm/cubature.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

namespace irdm
{
  namespace
  {
    // Lawson and Hanson's active-set method on the normal equations (AtA, Atb): the passive
    // set's subproblem is a small Cholesky solve. A start (non-negative; its positive entries
    // the first passive set) saves the outer iterations a nearby problem already made.
    Eigen::VectorXd
    nnls_normal(const Eigen::MatrixXd &AtA, const Eigen::VectorXd &Atb,
                const Eigen::VectorXd &start = Eigen::VectorXd())
    {
      const Eigen::Index n = Atb.size();
      Eigen::VectorXd    x = Eigen::VectorXd::Zero(n), z(n);
      std::vector<char>  passive(n, 0);
      if (start.size() == n)
        for (Eigen::Index i = 0; i < n; ++i)
          if (start(i) > 0)
            x(i) = start(i), passive[i] = 1;
      const double       tol = 1e-12 * std::max(Atb.cwiseAbs().maxCoeff(), 1e-300);
      const auto solve_passive = [&]() {
        std::vector<Eigen::Index> P;
        for (Eigen::Index i = 0; i < n; ++i)
          if (passive[i])
            P.push_back(i);
        Eigen::MatrixXd A(P.size(), P.size());
        Eigen::VectorXd b(P.size());
        for (size_t i = 0; i < P.size(); ++i)
          {
            b(i) = Atb(P[i]);
            for (size_t j = 0; j < P.size(); ++j)
              A(i, j) = AtA(P[i], P[j]);
          }
        const Eigen::VectorXd y = A.ldlt().solve(b);
        z.setZero();
        for (size_t i = 0; i < P.size(); ++i)
          z(P[i]) = y(i);
      };
      for (Eigen::Index outer = 0; outer < 3 * n + 10; ++outer)
        {
          const Eigen::VectorXd w = Atb - AtA * x;
          Eigen::Index          j = -1;
          for (Eigen::Index i = 0; i < n; ++i)
            if (!passive[i] && w(i) > tol && (j < 0 || w(i) > w(j)))
              j = i;
          if (j < 0)
            break;
          passive[j] = 1;
          for (Eigen::Index inner = 0; inner < 3 * n + 10; ++inner)
            {
              solve_passive();
              double alpha = 2;
              for (Eigen::Index i = 0; i < n; ++i)
                if (passive[i] && z(i) <= 0)
                  alpha = std::min(alpha, x(i) / (x(i) - z(i)));
              if (alpha > 1)
                {
                  x = z;
                  break;
                }
              x += alpha * (z - x);
              for (Eigen::Index i = 0; i < n; ++i)
                if (passive[i] && x(i) <= tol * 1e-3)
                  passive[i] = 0, x(i) = 0;
            }
        }
      return x;
    }
  } // namespace

  Eigen::VectorXd
  non_negative_least_squares(const Eigen::MatrixXd &A, const Eigen::VectorXd &b)
  {
    return nnls_normal(A.transpose() * A, A.transpose() * b);
  }

  TrainingSet
  training_presses(const ReducedNonlinearModel &m, const TrainingOptions &o)
  {
    if (o.presses == 0 || o.ramp_steps == 0 || o.every == 0 || !(o.max_depth > 0))
      throw InputError("training needs at least one press, a positive depth and ramp");
    TrainingSet                            out;
    std::mt19937                           rng(o.seed);
    std::normal_distribution<double>       normal(0, 1);
    std::uniform_real_distribution<double> uniform(0.2, 1);
    for (unsigned p = 0; p < o.presses; ++p)
      {
        Eigen::Vector3d d(normal(rng), normal(rng), normal(rng));
        d.normalize();
        double support = -INFINITY; // of the vertices with a free DoF
        for (size_t s = 0; s < m.coordinates.size(); ++s)
          if (m.free_dof[s][0] || m.free_dof[s][1] || m.free_dof[s][2])
            support = std::max(support, d.dot(Eigen::Vector3d(m.coordinates[s][0], m.coordinates[s][1],
                                                              m.coordinates[s][2])));
        out.directions.push_back({d(0), d(1), d(2)});
        out.supports.push_back(support);
        out.depths.push_back(o.max_depth * uniform(rng));
      }
    return out;
  }

  TrainingSet
  training_states(const ReducedNonlinearModel &m, const TrainingOptions &o)
  {
    if (!m.every_element)
      throw InputError("training states come from a reduced model with every element");
    TrainingSet out = training_presses(m, o);
    out.source      = "reduced_model";
    for (size_t p = 0; p < out.depths.size(); ++p)
      {
        const Eigen::Vector3d d(out.directions[p][0], out.directions[p][1], out.directions[p][2]);
        ReducedNonlinearBody  body(m);
        ReducedPlane          plane;
        plane.normal = {-d(0), -d(1), -d(2)};
        for (unsigned k = 1; k <= 2 * o.ramp_steps; ++k)
          {
            const double in = out.depths[p] * std::min(1.0, double(k) / o.ramp_steps);
            for (int i = 0; i < 3; ++i)
              plane.point[i] = (out.supports[p] - in) * d(i);
            body.step(&plane, 1);
            if (k % o.every == 0)
              out.states.push_back(body.coordinates());
          }
        out.failed_steps += body.failed_steps();
        if (o.log)
          o.log("training press " + std::to_string(p + 1) + " of " + std::to_string(out.depths.size()) +
                ": " + std::to_string(1e3 * out.depths[p]) + " mm");
      }
    return out;
  }

  Cubature
  train_cubature(const ReducedNonlinearModel &m, const std::vector<Eigen::VectorXd> &states,
                 const CubatureOptions &o)
  {
    const auto t0 = std::chrono::steady_clock::now();
    if (!m.every_element)
      throw InputError("a cubature is trained on a reduced model with every element");
    if (states.empty())
      throw InputError("a cubature needs training states");
    if (!(o.tolerance > 0) || o.max_elements == 0)
      throw InputError("a cubature needs a positive tolerance and room for an element");
    const unsigned     r = m.size;
    const Eigen::Index E = static_cast<Eigen::Index>(m.elements.size());
    // G: column e holds element e's reduced force at every state (state k's block scaled by
    // one over every element's total there).
    std::vector<Eigen::VectorXd> kept; // states whose total force is not zero
    std::vector<Eigen::MatrixXd> element_basis(E, Eigen::MatrixXd(12, r));
    for (Eigen::Index e = 0; e < E; ++e)
      for (int i = 0; i < 4; ++i)
        for (int d = 0; d < 3; ++d)
          element_basis[e].row(3 * i + d) =
            Eigen::Map<const Eigen::RowVectorXd>(&m.basis[(3 * size_t(m.tetrahedra[e][i]) + d) * r], r);
    Eigen::MatrixXd   G(static_cast<Eigen::Index>(states.size()) * r, E);
    Eigen::VectorXd   b(G.rows());
    elastic::Vector12 u_e, f_e;
    Eigen::Index      rows = 0;
    for (const auto &q : states)
      {
        Eigen::MatrixXd block(r, E);
        bool            ok = true;
        for (Eigen::Index e = 0; e < E && ok; ++e)
          {
            u_e = element_basis[e] * q;
            ok  = elastic::neo_hookean_force(m.elements[e], u_e, m.mu, m.lambda, f_e);
            block.col(e) = element_basis[e].transpose() * f_e;
          }
        const Eigen::VectorXd total = block.rowwise().sum();
        if (!ok || !(total.norm() > 0))
          continue;
        G.middleRows(rows, r) = block / total.norm();
        b.segment(rows, r)    = total / total.norm();
        rows += r;
      }
    G.conservativeResize(rows, E);
    b.conservativeResize(rows);
    if (rows == 0)
      throw InputError("a cubature needs a training state with an internal force");
    const Eigen::VectorXd column_norm = G.colwise().norm();
    Cubature              c;
    c.n_states = static_cast<unsigned>(rows / r);
    std::vector<char> chosen(E, 0);
    Eigen::VectorXd   residual = b, w;
    // The chosen columns' normal equations, grown by one row and column per element (never
    // formed again from the columns: that is O(rows n^2) per element).
    const Eigen::Index capacity = std::min<Eigen::Index>(o.max_elements, E);
    Eigen::MatrixXd    gram(capacity, capacity);
    Eigen::VectorXd    Gtb(capacity);
    const double       b_norm = b.norm();
    while (c.elements.size() < std::min<size_t>(o.max_elements, E))
      {
        c.training_error = residual.norm() / b_norm;
        if (c.training_error <= o.tolerance)
          break;
        const Eigen::VectorXd score = G.transpose() * residual;
        Eigen::Index          best  = -1;
        for (Eigen::Index e = 0; e < E; ++e)
          if (!chosen[e] && column_norm(e) > 0 &&
              (best < 0 || score(e) / column_norm(e) > score(best) / column_norm(best)))
            best = e;
        if (best < 0 || !(score(best) > 0))
          break; // no element moves the residual any more
        chosen[best]         = 1;
        const Eigen::Index n = static_cast<Eigen::Index>(c.elements.size());
        c.elements.push_back(static_cast<unsigned>(best));
        for (Eigen::Index i = 0; i < n; ++i)
          gram(i, n) = gram(n, i) = G.col(c.elements[i]).dot(G.col(best));
        gram(n, n) = G.col(best).squaredNorm();
        Gtb(n)     = G.col(best).dot(b);
        Eigen::VectorXd start(n + 1);
        start.head(n) = w.size() == n ? w : Eigen::VectorXd::Zero(n);
        start(n)      = 0;
        w             = nnls_normal(gram.topLeftCorner(n + 1, n + 1), Gtb.head(n + 1), start);
        residual      = b;
        for (Eigen::Index i = 0; i <= n; ++i)
          if (w(i) > 0)
            residual -= w(i) * G.col(c.elements[i]);
      }
    c.training_error = residual.norm() / b_norm;
    // Elements whose weight came out zero are left out.
    Cubature out = c;
    out.elements.clear();
    for (size_t k = 0; k < c.elements.size(); ++k)
      if (w(k) > 0)
        {
          out.elements.push_back(c.elements[k]);
          out.weights.push_back(w(k));
        }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o.log)
      o.log("cubature: " + std::to_string(out.elements.size()) + " of " + std::to_string(E) +
            " elements, training residual " + std::to_string(out.training_error) + " over " +
            std::to_string(out.n_states) + " states, " + std::to_string(out.seconds) + " s");
    return out;
  }

  void
  write_cubature_model(const std::string &source, const std::string &output, const Cubature &c,
                       const TrainingSet &training)
  {
    const h5::Reader in(source);
    h5::Writer       f(output);
    f.copy_root_attributes(in, {});
    for (const char *group : {"/basis", "/mesh", "/surface"})
      f.copy_from(in, group);
    f.create_group("/cubature");
    std::vector<long long> ids(c.elements.begin(), c.elements.end());
    f.write("/cubature/elements", {ids.size()}, ids.data());
    f.write("/cubature/weights", {c.weights.size()}, c.weights.data());
    f.attribute("/cubature", "training_error", c.training_error);
    f.attribute("/cubature", "training_states", static_cast<long long>(c.n_states));
    f.attribute("/cubature", "training_presses", static_cast<long long>(training.depths.size()));
    f.attribute("/cubature", "training_failed_steps", static_cast<long long>(training.failed_steps));
    f.attribute("/cubature", "training_source", training.source);
    if (!training.depths.empty())
      {
        std::vector<double> dirs;
        for (const auto &d : training.directions)
          dirs.insert(dirs.end(), d.begin(), d.end());
        f.write("/cubature/training_directions", {training.directions.size(), 3}, dirs.data());
        f.write("/cubature/training_depths_m", {training.depths.size()}, training.depths.data());
      }
    f.commit();
  }
} // namespace irdm
