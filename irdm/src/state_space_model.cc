#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <initializer_list>
#include <memory>
#include <random>

#include "frame.h"
#include "realization.h"

namespace irdm
{
  namespace
  {
    using Mat = Eigen::MatrixXd;
    using Vec = Eigen::VectorXd;

    // H[s] as an outputs x inputs matrix.
    Mat
    sample(const ImpulseResponseModel &m, const unsigned s)
    {
      Mat h(m.n_outputs, m.n_inputs);
      for (unsigned k = 0; k < m.n_inputs; ++k)
        for (unsigned j = 0; j < m.n_outputs; ++j)
          h(j, k) = m.h(k, s, j);
      return h;
    }

    // The r leading eigenvectors of a symmetric positive semi-definite Gram matrix (its lower
    // triangle), largest first: the leading singular vectors of the matrix it was made from.
    Mat
    leading_vectors(const Mat &gram, const unsigned r)
    {
      const Eigen::SelfAdjointEigenSolver<Mat> es(gram);
      if (es.info() != Eigen::Success)
        throw InputError("era: the responses' directions could not be found (eigensolver)");
      return es.eigenvectors().rightCols(r).rowwise().reverse();
    }

  } // namespace

  namespace realization
  {
    // The leading k singular triplets of a (randomized range finder with two power steps,
    // then the exact SVD of the small projected matrix; Halko, Martinsson and Tropp 2011).
    Svd
    leading_svd(const Mat &a, const unsigned k)
    {
      const Eigen::Index n = std::min(a.rows(), a.cols());
      Svd                out;
      if (k + 30 >= static_cast<unsigned>(n))
        {
          const Eigen::BDCSVD<Mat> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
          out.U = svd.matrixU(), out.V = svd.matrixV(), out.sigma = svd.singularValues();
          return out;
        }
      std::mt19937                     rng(12345); // a fixed sketch: the same data, the same model
      std::normal_distribution<double> normal;
      Mat omega(a.cols(), k + 30);
      for (Eigen::Index i = 0; i < omega.size(); ++i)
        omega.data()[i] = normal(rng);
      Mat q = (a * omega).householderQr().householderQ() * Mat::Identity(a.rows(), omega.cols());
      for (int power = 0; power < 2; ++power)
        {
          const Mat z = (a.transpose() * q).householderQr().householderQ() *
                        Mat::Identity(a.cols(), omega.cols());
          q = (a * z).householderQr().householderQ() * Mat::Identity(a.rows(), omega.cols());
        }
      const Mat                small = q.transpose() * a;
      const Eigen::BDCSVD<Mat> svd(small, Eigen::ComputeThinU | Eigen::ComputeThinV);
      out.U     = q * svd.matrixU();
      out.V     = svd.matrixV();
      out.sigma = svd.singularValues();
      return out;
    }

    // A in real block-diagonal form: T^-1 A T = diag(real poles, [a b; -b a] per pair), with
    // T's columns the eigenvectors (real parts and imaginary parts of each pair's). Poles
    // beyond the radius are pulled onto it.
    void
    set_block_diagonal(StateSpaceModel &out, const Mat &A, const Mat &B, const Mat &C,
                       const double radius)
    {
      const Eigen::EigenSolver<Mat> es(A);
      if (es.info() != Eigen::Success)
        throw InputError("era: the eigenvalues of the identified A could not be found");
      const Eigen::Index n = A.rows();
      std::vector<Eigen::Index> real, pairs;
      for (Eigen::Index i = 0; i < n; ++i)
        {
          const double im = es.eigenvalues()[i].imag();
          if (im == 0)
            real.push_back(i);
          else if (im > 0)
            pairs.push_back(i);
        }
      if (real.size() + 2 * pairs.size() != static_cast<size_t>(n))
        throw InputError("era: the eigenvalues of A do not come in conjugate pairs");
      Mat          T(n, n);
      Eigen::Index col = 0;
      for (const auto i : real)
        T.col(col++) = es.eigenvectors().col(i).real();
      for (const auto i : pairs)
        {
          T.col(col++) = es.eigenvectors().col(i).real();
          T.col(col++) = es.eigenvectors().col(i).imag();
        }
      const Eigen::PartialPivLU<Mat> lu(T);
      if (!(lu.rcond() > 1e-13))
        throw InputError("era: the identified A has no basis of eigenvectors (condition " +
                         std::to_string(1 / lu.rcond()) + "); try another --order");
      out.order  = static_cast<unsigned>(n);
      out.n_real = static_cast<unsigned>(real.size());
      out.real_poles.clear();
      out.complex_poles.clear();
      out.poles_pulled_in = 0;
      const auto pull     = [&](std::complex<double> z) {
        if (std::abs(z) > radius)
          {
            out.poles_pulled_in += z.imag() == 0 ? 1 : 2;
            z *= radius / std::abs(z);
          }
        return z;
      };
      for (const auto i : real)
        out.real_poles.push_back(pull(es.eigenvalues()[i]).real());
      for (const auto i : pairs)
        {
          const std::complex<double> z = pull(es.eigenvalues()[i]);
          out.complex_poles.push_back(z.real());
          out.complex_poles.push_back(z.imag());
        }
      const Mat Bt = lu.solve(B); // n x inputs
      const Mat Ct = C * T;       // outputs x n
      out.b.resize(static_cast<size_t>(out.n_inputs) * n);
      out.c.resize(static_cast<size_t>(C.rows()) * n);
      Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        out.c.data(), C.rows(), n) = Ct.cast<float>();
      Eigen::Map<Mat>(out.b.data(), n, out.n_inputs) = Bt; // column k contiguous: [k][state]
    }
  } // namespace realization

  double
  StateSpaceModel::response(const unsigned k, const unsigned s, const unsigned j) const
  {
    if (s == 0)
      return d[static_cast<size_t>(k) * n_outputs + j];
    std::vector<double> x(b.begin() + static_cast<long>(k) * order,
                          b.begin() + static_cast<long>(k + 1) * order);
    for (unsigned step = 1; step < s; ++step)
      {
        for (unsigned i = 0; i < n_real; ++i)
          x[i] *= real_poles[i];
        for (unsigned p = 0; p < n_pairs(); ++p)
          {
            const double a = complex_poles[2 * p], w = complex_poles[2 * p + 1];
            double      &xr = x[n_real + 2 * p], &xi = x[n_real + 2 * p + 1];
            const double r  = a * xr + w * xi;
            xi              = -w * xr + a * xi;
            xr              = r;
          }
      }
    const auto y = [&](const unsigned dir) {
      double sum = 0;
      for (unsigned i = 0; i < order; ++i)
        sum += c[static_cast<size_t>(dir) * order + i] * x[i];
      return sum;
    };
    if (output_basis.empty())
      return y(j);
    double u = 0;
    for (unsigned dir = 0; dir < output_dimension; ++dir)
      u += output_basis[static_cast<size_t>(j) * output_dimension + dir] * y(dir);
    return u;
  }

  double
  StateSpaceModel::bytes() const
  {
    return 8.0 * (real_poles.size() + complex_poles.size() + b.size() + d.size()) +
           4.0 * (output_basis.size() + c.size() + contact_direction.size());
  }

  struct EraHankel
  {
    EraOptions        options; // order: the largest a realization may take
    unsigned          ri = 0, ro = 0, n_contact = 0, p = 0, q = 0;
    std::vector<char> contact_row; // [output DoF]: an input vertex's own
    Mat               Uo, Ui;      // the output and input directions
    Vec               sigma;       // Hankel singular values, every one computed
    Mat               U_top, V_top; // U's first ro rows, V's first ri rows (the first blocks)
    Mat               M;            // U^T H1 V
    double            seconds = 0;
  };

  std::shared_ptr<const EraHankel>
  prepare_era(const ImpulseResponseModel &m, const EraOptions &o)
  {
    const auto t0  = std::chrono::steady_clock::now();
    const auto log = [&](const std::string &s) {
      if (o.log)
        o.log(s);
    };
    if (m.modal_only)
      throw InputError("era: the model holds no H (written with --modal-only); identification "
                       "needs the responses");
    if (m.length < 3)
      throw InputError("era: the responses need at least 3 samples");
    const unsigned nin = m.n_inputs, nout = m.n_outputs;
    // Outputs: the input vertices' own DoFs exactly (the contact rows, whose history the
    // force loop reads and a rigid probe divides by the small feed-through), then the
    // dominant directions of the other outputs. Inputs: their dominant directions.
    const unsigned ri = std::min(nin, o.input_directions ? o.input_directions : 1000u);
    std::vector<char> contact_row(nout, 0);
    for (unsigned v = 0; v < m.input_output_index.size(); ++v)
      for (unsigned a = 0; a < 3; ++a)
        contact_row[3 * m.input_output_index[v] + a] = 1;
    const unsigned n_contact = static_cast<unsigned>(std::count(contact_row.begin(), contact_row.end(), 1));
    const unsigned ro        = std::min(nout, n_contact + o.output_directions);
    // Block rows p (outputs) and columns q (inputs), each to about 4000 scalar rows or
    // columns unless given; samples 1 .. p + q, which the response must hold.
    unsigned p = o.hankel_rows ? o.hankel_rows : std::max(1u, 4000 / ro);
    unsigned q = o.hankel_columns ? o.hankel_columns : std::max(1u, 4000 / ri);
    if (o.hankel_rows + o.hankel_columns > m.length - 1)
      throw InputError("era: --hankel-rows plus --hankel-columns must be below the response "
                       "length " + std::to_string(m.length));
    // Within the length, shrinking only what was not given (the larger of the two if neither).
    while (p + q > m.length - 1)
      (o.hankel_rows ? q : o.hankel_columns ? p : p > q ? p : q) -= 1;
    const unsigned bound = std::min(p * ro, q * ri);
    if (o.order == 0 || o.order > bound)
      throw InputError("era: order " + std::to_string(o.order) + " exceeds the Hankel matrix's rank bound " +
                       std::to_string(bound) + " (" + std::to_string(p) + " x " +
                       std::to_string(ro) + " rows, " + std::to_string(q) + " x " +
                       std::to_string(ri) + " columns); lower --order");
    if (!(o.stability_radius > 0 && o.stability_radius <= 1 - 1e-9))
      throw InputError("era: the stability radius must be in (0, 1 - 1e-9]");

    // The dominant output and input directions of the samples the Hankel matrix uses.
    log("era: directions (" + std::to_string(ro) + " out, " + std::to_string(ri) + " in) over " +
        std::to_string(p + q) + " samples");
    // Two passes over H (every sample read again, never all held in double): the Gram
    // matrices, then the projected samples.
    Mat gram_out = Mat::Zero(nout, nout), gram_in = Mat::Zero(nin, nin);
    if (ro < nout || ri < nin)
      for (unsigned s = 1; s <= p + q; ++s)
        {
          Mat h = sample(m, s);
          if (ri < nin)
            gram_in.selfadjointView<Eigen::Lower>().rankUpdate(h.transpose());
          for (unsigned j = 0; j < nout; ++j)
            if (contact_row[j])
              h.row(j).setZero();
          if (ro < nout)
            gram_out.selfadjointView<Eigen::Lower>().rankUpdate(h);
        }
    auto e = std::make_shared<EraHankel>();
    e->options = o, e->ri = ri, e->ro = ro, e->n_contact = n_contact, e->p = p, e->q = q;
    e->contact_row = contact_row;
    e->Uo          = Mat::Identity(nout, nout);
    if (ro < nout)
      {
        Mat rest = leading_vectors(gram_out, ro - n_contact);
        for (unsigned j = 0; j < nout; ++j)
          if (contact_row[j])
            rest.row(j).setZero();
        e->Uo.setZero(nout, ro);
        for (unsigned j = 0, c = 0; j < nout; ++j)
          if (contact_row[j])
            e->Uo(j, c++) = 1;
        e->Uo.rightCols(ro - n_contact) = rest.householderQr().householderQ() *
                                          Mat::Identity(nout, ro - n_contact);
      }
    e->Ui = ri < nin ? leading_vectors(gram_in, ri) : Mat::Identity(nin, nin);
    std::vector<Mat> samples(p + q + 1);
    for (unsigned s = 1; s <= p + q; ++s)
      samples[s] = e->Uo.transpose() * sample(m, s) * e->Ui; // ro x ri

    // Hankel matrices of the projected samples: H0 (i, j) = Y[1 + i + j], H1 shifted by one.
    Mat H0(p * ro, q * ri), H1(p * ro, q * ri);
    for (unsigned i = 0; i < p; ++i)
      for (unsigned j = 0; j < q; ++j)
        {
          H0.block(i * ro, j * ri, ro, ri) = samples[1 + i + j];
          H1.block(i * ro, j * ri, ro, ri) = samples[2 + i + j];
        }
    samples.clear();
    log("era: SVD of the " + std::to_string(H0.rows()) + " x " + std::to_string(H0.cols()) +
        " Hankel matrix");
    const realization::Svd svd = realization::leading_svd(H0, o.order);
    e->sigma      = svd.sigma;
    e->U_top      = svd.U.topRows(ro);
    e->V_top      = svd.V.topRows(ri);
    e->M          = svd.U.transpose() * H1 * svd.V;
    e->seconds    = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return e;
  }

  StateSpaceModel
  realize_era(const ImpulseResponseModel &m, const EraHankel &e, const unsigned r)
  {
    const auto t0 = std::chrono::steady_clock::now();
    if (r == 0 || r > e.options.order)
      throw InputError("era: order " + std::to_string(r) + " is not within 1 .. " +
                       std::to_string(e.options.order) + ", the order the Hankel matrix was "
                       "prepared for");
    if (!(e.sigma[r - 1] > 1e-14 * e.sigma[0]))
      throw InputError("era: the Hankel matrix has rank below order " + std::to_string(r) +
                       " (its singular value " + std::to_string(r) + " is zero to round-off); "
                       "lower --order");
    const unsigned nin = m.n_inputs, nout = m.n_outputs, ro = e.ro, ri = e.ri;
    const Vec sq = e.sigma.head(r).cwiseSqrt(), isq = sq.cwiseInverse();
    const Mat A  = isq.asDiagonal() * e.M.topLeftCorner(r, r) * isq.asDiagonal();
    const Mat Bp = sq.asDiagonal() * e.V_top.leftCols(r).transpose() * e.Ui.transpose(); // r x nin
    const Mat Cp = e.U_top.leftCols(r) * sq.asDiagonal(); // ro x r: the outputs are Uo Cp x

    StateSpaceModel out;
    static_cast<ModelFrame &>(out) = m;
    out.input_directions  = ri;
    out.output_directions = ro - e.n_contact;
    out.hankel_rows       = e.p;
    out.hankel_columns    = e.q;
    out.stability_radius  = e.options.stability_radius;
    out.hankel_singular_values.assign(e.sigma.data(), e.sigma.data() + e.sigma.size());
    realization::set_block_diagonal(out, A, Bp, Cp, e.options.stability_radius);
    out.output_dimension = ro;
    if (ro < nout)
      {
        out.output_basis.resize(static_cast<size_t>(nout) * ro);
        Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          out.output_basis.data(), nout, ro) = e.Uo.cast<float>();
      }
    out.contact_direction.resize(nin);
    for (unsigned k = 0; k < nin; ++k)
      {
        const unsigned j = 3 * m.input_output_index[k / 3] + k % 3;
        // Without a basis the directions are the outputs; with one, the contact rows come
        // first in output order.
        out.contact_direction[k] =
          ro == nout ? j
                     : static_cast<unsigned>(std::count(e.contact_row.begin(), e.contact_row.begin() + j, 1));
      }
    realization::set_feedthrough_from_h(out, m);
    out.identification_seconds =
      e.seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  StateSpaceModel
  identify_era(const ImpulseResponseModel &m, const EraOptions &o)
  {
    return realize_era(m, *prepare_era(m, o), o.order);
  }

  void
  save_state_space_model(const StateSpaceModel &m, const std::string &source_file,
                         const std::string &path, OutputLock lock)
  {
    const h5::Reader source(source_file);
    h5::Writer       f(path, h5::Writer::Mode::create, std::move(lock));
    f.copy_root_attributes(source, {"format", "format_version", "impulse_response"});
    f.attribute("/", "format", std::string("irdm-state-space-model"));
    f.attribute("/", "format_version", 1LL);
    f.attribute("/", "source_file", source_file);
    const bool balanced = m.method == "balanced_truncation";
    f.attribute("/", "method", m.method);
    f.attribute("/", "identified_from", m.identified_from);
    f.attribute("/", "identification",
                std::string(balanced ? "balanced truncation (square-root method) of the source's "
                                       "modal realization"
                                     : "eigensystem realization algorithm (Ho-Kalman, "
                                       "Juang-Pappa) from H alone") +
                  ": x[n+1] = A x[n] + B f[n], u[n] = C x[n] + D f[n], D = H[0]; "
                  "docs/compression.md");
    f.attribute("/", "order", static_cast<long long>(m.order));
    f.attribute("/", "output_dimension", static_cast<long long>(m.output_dimension));
    f.attribute("/", "n_hankel_singular_values",
                static_cast<long long>(m.hankel_singular_values.size()));
    f.attribute("/", "n_real_poles", static_cast<long long>(m.n_real));
    f.attribute("/", "input_directions", static_cast<long long>(m.input_directions));
    f.attribute("/", "output_directions", static_cast<long long>(m.output_directions));
    f.attribute("/", "hankel_block_rows", static_cast<long long>(m.hankel_rows));
    f.attribute("/", "hankel_block_columns", static_cast<long long>(m.hankel_columns));
    f.attribute("/", "stability_radius", m.stability_radius);
    f.attribute("/", "poles_pulled_in", static_cast<long long>(m.poles_pulled_in));
    f.attribute("/", "identification_seconds", m.identification_seconds);
    for (const char *g : {"/outputs", "/inputs", "/surface"})
      f.copy_from(source, g);
    if (m.free_body)
      f.copy_from(source, "/rigid_body");
    f.create_group("/state_space");
    std::vector<double> poles;
    for (const double z : m.real_poles)
      poles.push_back(z), poles.push_back(0.0);
    poles.insert(poles.end(), m.complex_poles.begin(), m.complex_poles.end());
    const hsize_t r = m.order;
    f.write("/state_space/poles", {m.n_real + m.n_pairs(), 2}, poles.data());
    f.write("/state_space/B", {m.n_inputs, r}, m.b.data());
    f.write("/state_space/C", {m.output_dimension, r}, m.c.data());
    if (!m.output_basis.empty())
      f.write("/state_space/output_basis", {m.n_outputs, m.output_dimension}, m.output_basis.data());
    const std::vector<long long> contact(m.contact_direction.begin(), m.contact_direction.end());
    f.write("/state_space/contact_direction", {contact.size()}, contact.data());
    f.write("/state_space/D", {m.n_inputs, m.n_outputs}, m.d.data());
    f.write("/state_space/hankel_singular_values", {m.hankel_singular_values.size()},
            m.hankel_singular_values.data());
    f.commit();
  }

  StateSpaceModel
  load_state_space_model(const std::string &path, const std::optional<double> expected_time_step)
  {
    const h5::Reader r(path);
    const auto       fail = [&](const std::string &what) -> void {
      throw InputError("state-space model '" + path + "': " + what);
    };
    if (!r.has_attribute("/", "format") ||
        r.string_attribute("/", "format") != "irdm-state-space-model")
      fail("not a state-space model (attribute 'format' is missing or different)");
    if (r.double_attribute("/", "format_version") != 1)
      fail("format version not supported (this build reads 1)");
    StateSpaceModel m;
    read_frame(r, path, m, expected_time_step);
    m.order  = static_cast<unsigned>(r.count_attribute("/", "order", 1, 1000000));
    m.n_real = static_cast<unsigned>(r.count_attribute("/", "n_real_poles", 0, m.order));
    if ((m.order - m.n_real) % 2 != 0)
      fail("order less the real poles must be even (complex poles come in pairs)");
    m.input_directions  = static_cast<unsigned>(r.count_attribute("/", "input_directions", 1, m.n_inputs));
    m.output_directions = static_cast<unsigned>(r.count_attribute("/", "output_directions", 0, m.n_outputs));
    // Files before the attribute are ERA's; balanced truncation builds no Hankel matrix of H.
    m.method = r.has_attribute("/", "method") ? r.string_attribute("/", "method") : "era";
    if (m.method != "era" && m.method != "balanced_truncation")
      fail("method must be era or balanced_truncation");
    if (r.has_attribute("/", "identified_from"))
      m.identified_from = r.string_attribute("/", "identified_from");
    const long long least = m.method == "era" ? 1 : 0;
    m.hankel_rows      = static_cast<unsigned>(r.count_attribute("/", "hankel_block_rows", least, m.length));
    m.hankel_columns   = static_cast<unsigned>(r.count_attribute("/", "hankel_block_columns", least, m.length));
    m.poles_pulled_in  = static_cast<unsigned>(r.count_attribute("/", "poles_pulled_in", 0, m.order));
    m.stability_radius = r.double_attribute("/", "stability_radius");
    m.identification_seconds = r.double_attribute("/", "identification_seconds");
    m.source_file      = r.string_attribute("/", "source_file");
    const hsize_t n    = m.order;
    const auto poles   = r.read_double("/state_space/poles", {m.n_real + m.n_pairs(), 2});
    m.b                = r.read_double("/state_space/B", {m.n_inputs, n});
    m.output_dimension = static_cast<unsigned>(r.count_attribute("/", "output_dimension", 1, m.n_outputs));
    const unsigned ro  = m.output_dimension;
    m.c                = r.read_float("/state_space/C", {ro, n});
    if (ro < m.n_outputs)
      m.output_basis = r.read_float("/state_space/output_basis", {m.n_outputs, ro});
    else if (r.exists("/state_space/output_basis"))
      fail("an output basis with as many directions as outputs (the identity is not stored)");
    // The runtime reads an input's output as one row of C: its basis row must be that
    // direction's unit vector (without a basis, the direction is the output itself).
    const auto contact = r.read_int("/state_space/contact_direction", {m.n_inputs});
    for (unsigned k = 0; k < m.n_inputs; ++k)
      {
        const unsigned j = 3 * m.input_output_index[k / 3] + k % 3;
        if (contact[k] < 0 || contact[k] >= ro)
          fail("contact_direction " + std::to_string(k) + " is out of range");
        bool unit = m.output_basis.empty() ? contact[k] == j : true;
        for (unsigned dir = 0; unit && dir < ro && !m.output_basis.empty(); ++dir)
          unit = m.output_basis[static_cast<size_t>(j) * ro + dir] == (dir == contact[k] ? 1.0f : 0.0f);
        if (!unit)
          fail("contact_direction " + std::to_string(k) + " does not pick its output exactly");
        m.contact_direction.push_back(static_cast<unsigned>(contact[k]));
      }
    m.d                = r.read_double("/state_space/D", {m.n_inputs, m.n_outputs});
    const hsize_t n_hsv = static_cast<hsize_t>(
      r.count_attribute("/", "n_hankel_singular_values", m.order, 100000000));
    m.hankel_singular_values = r.read_double("/state_space/hankel_singular_values", {n_hsv});
    for (const std::vector<double> *v :
         std::initializer_list<const std::vector<double> *>{&poles, &m.b, &m.d,
                                                          &m.hankel_singular_values})
      for (const double x : *v)
        if (!std::isfinite(x))
          fail("the realization contains NaN or Inf");
    for (const std::vector<float> *v : std::initializer_list<const std::vector<float> *>{&m.c, &m.output_basis})
      for (const float x : *v)
        if (!std::isfinite(x))
          fail("the realization contains NaN or Inf");
    // The runtime steps x[n + 1] = A x[n]: a pole on or beyond the unit circle would grow
    // without bound, so such a file is refused, not run.
    for (unsigned i = 0; i < m.n_real; ++i)
      {
        if (!(std::abs(poles[2 * i]) < 1) || poles[2 * i + 1] != 0)
          fail("real pole " + std::to_string(i) + " is not a real number inside the unit circle");
        m.real_poles.push_back(poles[2 * i]);
      }
    for (unsigned p = 0; p < m.n_pairs(); ++p)
      {
        const double a = poles[2 * (m.n_real + p)], b = poles[2 * (m.n_real + p) + 1];
        if (!(std::hypot(a, b) < 1) || !(b > 0))
          fail("complex pole " + std::to_string(p) + " is not inside the unit circle with a "
               "positive imaginary part");
        m.complex_poles.push_back(a);
        m.complex_poles.push_back(b);
      }
    return m;
  }
} // namespace irdm
