#include <irdm/representative_model.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <Eigen/Dense>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <thread>

#include "frame.h"

namespace irdm
{
  double
  RepresentativeModel::bytes() const
  {
    return 4.0 * representatives.size() + 8.0 * first_representative.size() +
           (4.0 + 2.0 + 4.0) * term_amplitude.size();
  }

  double
  RepresentativeModel::response(const unsigned k, const unsigned s, const unsigned j) const
  {
    double       sum  = 0;
    const size_t base = (static_cast<size_t>(k) * n_outputs + j) * blend;
    for (unsigned b = 0; b < blend; ++b)
      {
        const float a = term_amplitude[base + b];
        const long  t = static_cast<long>(s) - term_delay[base + b];
        if (a == 0 || t < 0 || t >= static_cast<long>(length))
          continue;
        const size_t row = first_representative[k] + term_representative[base + b];
        sum += static_cast<double>(a) * representatives[row * length + t];
      }
    return sum;
  }

  namespace
  {
    using Clock = std::chrono::steady_clock;
    using VecF  = Eigen::Map<const Eigen::VectorXf>;

    // The compressed form of one input's waveforms.
    struct InputResult
    {
      std::vector<float>         representatives; // [r][s]
      std::vector<std::uint32_t> rep;             // [j][b]
      std::vector<std::uint16_t> delay;
      std::vector<float>         amplitude;
      std::uint64_t              n_substituted = 0;
      double                     fit_sum = 0, fit_min = 1, delay_sum = 0;
      unsigned                   delay_max = 0;
    };

    struct Candidate
    {
      unsigned rep   = 0;
      unsigned delay = 0;
      double   rho   = 0; // correlation at that delay (signed)
      double   dot   = 0; // <w, r shifted>
      double   norm2 = 0; // |r shifted|^2 inside the window
    };

    double
    distance2(const std::array<double, 3> &a, const std::array<double, 3> &b)
    {
      return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
             (a[2] - b[2]) * (a[2] - b[2]);
    }

    InputResult
    compress_input(const ImpulseResponseModel &m, const unsigned k, const CompressionOptions &o)
    {
      const unsigned T = m.length, nout = m.n_outputs, B = o.blend;
      const unsigned D = std::min(o.max_delay, T - 1);
      // Waveforms of input k, contiguous in s.
      std::vector<float>  w(static_cast<size_t>(nout) * T);
      std::vector<double> norm2(nout, 0.0);
      for (unsigned s = 0; s < T; ++s)
        for (unsigned j = 0; j < nout; ++j)
          w[static_cast<size_t>(j) * T + s] = static_cast<float>(m.h(k, s, j));
      for (unsigned j = 0; j < nout; ++j)
        norm2[j] = VecF(&w[static_cast<size_t>(j) * T], T).cast<double>().squaredNorm();
      // Visit outputs by distance from the input vertex (ties: larger waveform first).
      const auto &x_in = m.output_coordinates[m.input_output_index[k / 3]];
      std::vector<unsigned> order(nout);
      std::iota(order.begin(), order.end(), 0u);
      std::vector<double> dist(nout);
      for (unsigned j = 0; j < nout; ++j)
        dist[j] = distance2(m.output_coordinates[j / 3], x_in);
      std::stable_sort(order.begin(), order.end(), [&](unsigned a, unsigned b) {
        return dist[a] != dist[b] ? dist[a] < dist[b] : norm2[a] > norm2[b];
      });

      InputResult r;
      r.rep.assign(static_cast<size_t>(nout) * B, 0);
      r.delay.assign(static_cast<size_t>(nout) * B, 0);
      r.amplitude.assign(static_cast<size_t>(nout) * B, 0.0f);
      std::vector<unsigned>            rep_vertex;   // output vertex a representative came from
      std::vector<std::vector<double>> rep_prefix;   // prefix sums of r^2 (T + 1)
      std::vector<std::pair<double, unsigned>> near; // (distance^2, representative)
      std::vector<Candidate>           found;
      for (const unsigned j : order)
        {
          const float *wj = &w[static_cast<size_t>(j) * T];
          const size_t slot = static_cast<size_t>(j) * B;
          if (norm2[j] == 0) // nothing to store: all amplitudes 0
            {
              ++r.n_substituted;
              r.fit_sum += 1;
              continue;
            }
          // The nearest representatives of this input.
          near.clear();
          for (unsigned i = 0; i < rep_vertex.size(); ++i)
            near.emplace_back(distance2(m.output_coordinates[rep_vertex[i]],
                                        m.output_coordinates[j / 3]),
                              i);
          const size_t n_c = std::min<size_t>(o.candidates, near.size());
          std::partial_sort(near.begin(), near.begin() + n_c, near.end());
          // Best causal delay of each: the largest |correlation| of w with r shifted by d.
          found.clear();
          for (size_t c = 0; c < n_c; ++c)
            {
              const unsigned i  = near[c].second;
              const float   *ri = &r.representatives[static_cast<size_t>(i) * T];
              Candidate      best;
              best.rep = i;
              for (unsigned d = 0; d <= D; ++d)
                {
                  const double n2 = rep_prefix[i][T - d];
                  if (n2 <= 0)
                    break;
                  const double dot = VecF(wj + d, T - d).dot(VecF(ri, T - d));
                  const double rho = dot / std::sqrt(norm2[j] * n2);
                  if (std::abs(rho) > std::abs(best.rho))
                    best = {i, d, rho, dot, n2};
                }
              found.push_back(best);
            }
          std::sort(found.begin(), found.end(), [](const Candidate &a, const Candidate &b) {
            return std::abs(a.rho) > std::abs(b.rho);
          });
          double fit = 0;
          if (!found.empty() && B == 1)
            {
              fit = std::abs(found[0].rho);
              if (fit >= o.theta)
                {
                  r.rep[slot]       = found[0].rep;
                  r.delay[slot]     = static_cast<std::uint16_t>(found[0].delay);
                  r.amplitude[slot] = static_cast<float>(found[0].dot / found[0].norm2);
                }
            }
          else if (!found.empty())
            {
              // Interpolation: least-squares amplitudes of the best `blend` shifted
              // representatives; the fit is the correlation of w with its projection.
              const int      nb = static_cast<int>(std::min<size_t>(B, found.size()));
              Eigen::MatrixXd G(nb, nb);
              Eigen::VectorXd c(nb);
              for (int a = 0; a < nb; ++a)
                {
                  c[a] = found[a].dot;
                  for (int b = 0; b <= a; ++b)
                    {
                      // <r_a[. - d_a], r_b[. - d_b]> over the window 0 <= s < T.
                      const unsigned da = found[a].delay, db = found[b].delay;
                      const unsigned s0 = std::max(da, db);
                      const float *ra = &r.representatives[static_cast<size_t>(found[a].rep) * T];
                      const float *rb = &r.representatives[static_cast<size_t>(found[b].rep) * T];
                      G(a, b) = G(b, a) =
                        VecF(ra + (s0 - da), T - s0).dot(VecF(rb + (s0 - db), T - s0));
                    }
                }
              const Eigen::LDLT<Eigen::MatrixXd> ldlt(G);
              const Eigen::VectorXd              amp = ldlt.solve(c);
              const double explained = c.dot(amp);
              fit = amp.allFinite() && explained > 0 ? std::sqrt(std::min(1.0, explained / norm2[j])) : 0;
              if (fit >= o.theta)
                for (int b = 0; b < nb; ++b)
                  {
                    r.rep[slot + b]       = found[b].rep;
                    r.delay[slot + b]     = static_cast<std::uint16_t>(found[b].delay);
                    r.amplitude[slot + b] = static_cast<float>(amp[b]);
                  }
            }
          if (fit >= o.theta && !found.empty())
            {
              ++r.n_substituted;
              r.fit_sum += fit;
              r.fit_min = std::min(r.fit_min, fit);
              double dmean = 0, wsum = 0;
              for (unsigned b = 0; b < B; ++b)
                if (r.amplitude[slot + b] != 0)
                  {
                    r.delay_max = std::max<unsigned>(r.delay_max, r.delay[slot + b]);
                    dmean += r.delay[slot + b];
                    wsum += 1;
                  }
              r.delay_sum += wsum > 0 ? dmean / wsum : 0;
              continue;
            }
          // A new representative: the waveform itself.
          const unsigned i = static_cast<unsigned>(rep_vertex.size());
          r.representatives.insert(r.representatives.end(), wj, wj + T);
          rep_vertex.push_back(j / 3);
          std::vector<double> prefix(T + 1, 0.0);
          for (unsigned s = 0; s < T; ++s)
            prefix[s + 1] = prefix[s] + static_cast<double>(wj[s]) * wj[s];
          rep_prefix.push_back(std::move(prefix));
          r.rep[slot]       = i;
          r.delay[slot]     = 0;
          r.amplitude[slot] = 1.0f;
        }
      return r;
    }
  } // namespace

  RepresentativeModel
  compress(const ImpulseResponseModel &m, const CompressionOptions &o)
  {
    if (!(o.theta > 0 && o.theta <= 1))
      throw InputError("compress: theta must be in (0, 1], got " + std::to_string(o.theta));
    if (o.blend < 1 || o.blend > 4)
      throw InputError("compress: blend must be 1 to 4");
    if (o.candidates < o.blend)
      throw InputError("compress: candidates must be at least blend");
    if (o.max_delay > 65535)
      throw InputError("compress: max_delay must be below 65536 steps");
    const auto t0 = Clock::now();
    RepresentativeModel out;
    static_cast<ModelFrame &>(out) = m;
    out.theta      = o.theta;
    out.max_delay  = o.max_delay;
    out.blend      = o.blend;
    out.candidates = o.candidates;

    std::vector<InputResult> results(m.n_inputs);
    std::atomic<unsigned>    next{0}, done{0};
    std::mutex               log_mutex;
    const unsigned n_threads =
      o.threads > 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
    const auto work = [&] {
      for (unsigned k; (k = next++) < m.n_inputs;)
        {
          results[k]       = compress_input(m, k, o);
          const unsigned c = ++done;
          if (o.log && (c % std::max(1u, m.n_inputs / 10) == 0 || c == m.n_inputs))
            {
              std::lock_guard<std::mutex> lock(log_mutex);
              o.log("compressed " + std::to_string(c) + " of " + std::to_string(m.n_inputs) +
                    " inputs, " +
                    std::to_string(std::chrono::duration<double>(Clock::now() - t0).count()) + " s");
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < n_threads; ++t)
      pool.emplace_back(work);
    work();
    for (auto &t : pool)
      t.join();

    // Gather, in input order.
    const size_t slots = static_cast<size_t>(m.n_outputs) * o.blend;
    out.first_representative.assign(m.n_inputs + 1, 0);
    for (unsigned k = 0; k < m.n_inputs; ++k)
      out.first_representative[k + 1] =
        out.first_representative[k] + results[k].representatives.size() / m.length;
    out.representatives.reserve(out.first_representative.back() * m.length);
    out.term_representative.reserve(slots * m.n_inputs);
    out.term_delay.reserve(slots * m.n_inputs);
    out.term_amplitude.reserve(slots * m.n_inputs);
    double fit_sum = 0, delay_sum = 0;
    out.min_fit = 1;
    for (auto &r : results)
      {
        out.representatives.insert(out.representatives.end(), r.representatives.begin(),
                                   r.representatives.end());
        out.term_representative.insert(out.term_representative.end(), r.rep.begin(), r.rep.end());
        out.term_delay.insert(out.term_delay.end(), r.delay.begin(), r.delay.end());
        out.term_amplitude.insert(out.term_amplitude.end(), r.amplitude.begin(),
                                  r.amplitude.end());
        out.n_substituted += r.n_substituted;
        fit_sum += r.fit_sum;
        delay_sum += r.delay_sum;
        out.min_fit    = std::min(out.min_fit, r.fit_min);
        out.delay_span = std::max(out.delay_span, r.delay_max);
        r = InputResult();
      }
    out.mean_fit   = out.n_substituted > 0 ? fit_sum / out.n_substituted : 0;
    out.mean_delay = out.n_substituted > 0 ? delay_sum / out.n_substituted : 0;
    if (out.n_substituted == 0)
      out.min_fit = 0;
    out.compression_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return out;
  }

  void
  save_representative_model(const RepresentativeModel &m, const std::string &source_file,
                            const std::string &path, OutputLock lock)
  {
    // What the source model says of itself is copied through the checked reads: the source
    // is as untrusted as any input.
    const h5::Reader source(source_file);
    h5::Writer       f(path, h5::Writer::Mode::create, std::move(lock));
    f.copy_root_attributes(source, {"format", "format_version"});
    f.attribute("/", "format", std::string("irdm-representative-model"));
    f.attribute("/", "format_version", 1LL);
    f.attribute("/", "source_file", source_file);
    f.attribute("/", "compression",
                std::string("representative waveforms (seed 000 section 3): w[s] ~ sum_b a_b "
                            "r_b[s - d_b], causal delays d_b >= 0; docs/compression.md"));
    f.attribute("/", "theta", m.theta);
    f.attribute("/", "max_delay_steps", static_cast<long long>(m.max_delay));
    f.attribute("/", "delay_span_steps", static_cast<long long>(m.delay_span));
    f.attribute("/", "blend", static_cast<long long>(m.blend));
    f.attribute("/", "candidates", static_cast<long long>(m.candidates));
    f.attribute("/", "n_representative", static_cast<long long>(m.n_representative()));
    f.attribute("/", "n_substituted", static_cast<long long>(m.n_substituted));
    f.attribute("/", "mean_fit", m.mean_fit);
    f.attribute("/", "min_fit", m.min_fit);
    f.attribute("/", "mean_delay_steps", m.mean_delay);
    f.attribute("/", "compression_seconds", m.compression_seconds);
    f.attribute("/", "compressed_bytes", m.bytes());
    for (const char *g : {"/outputs", "/inputs", "/surface", "/modes"})
      if (source.exists(g)) // the modes are optional; the loader required the rest
        f.copy_from(source, g);
    if (m.free_body)
      f.copy_from(source, "/rigid_body");
    f.create_group("/representatives");
    f.write("/representatives/waveforms", {m.n_representative(), m.length},
            m.representatives.data());
    std::vector<long long> first(m.first_representative.begin(), m.first_representative.end());
    f.write("/representatives/first", {first.size()}, first.data());
    const std::vector<hsize_t> terms = {m.n_inputs, m.n_outputs, m.blend};
    std::vector<int> rep(m.term_representative.begin(), m.term_representative.end());
    f.write("/representatives/term_representative", terms, rep.data());
    f.write("/representatives/term_delay", terms, m.term_delay.data());
    f.write("/representatives/term_amplitude", terms, m.term_amplitude.data());
    f.commit();
  }

  RepresentativeModel
  load_representative_model(const std::string &path, const std::optional<double> expected_time_step)
  {
    h5::Reader r(path);
    const auto fail = [&](const std::string &what) -> void {
      throw InputError("compressed model '" + path + "': " + what);
    };
    if (!r.has_attribute("/", "format") ||
        r.string_attribute("/", "format") != "irdm-representative-model")
      fail("not a representative-waveform model (attribute 'format' is missing or different)");
    if (r.double_attribute("/", "format_version") != 1)
      fail("format version not supported (this build reads 1)");
    check_complete(r, path);
    RepresentativeModel m;
    read_frame(r, path, m, expected_time_step);
    // Counts are read as whole numbers in range: a delay span past the response length or a
    // negative one would size the runtime's ring buffers from garbage.
    const long long T     = m.length;
    m.theta               = r.double_attribute("/", "theta");
    m.max_delay           = static_cast<unsigned>(r.count_attribute("/", "max_delay_steps", 0, 65535));
    m.delay_span          = static_cast<unsigned>(r.count_attribute("/", "delay_span_steps", 0,
                                                                    std::min(T - 1, 65535LL)));
    m.blend               = static_cast<unsigned>(r.count_attribute("/", "blend", 1, 4));
    m.candidates          = static_cast<unsigned>(r.count_attribute("/", "candidates", 1, 1000000));
    m.mean_fit            = r.double_attribute("/", "mean_fit");
    m.min_fit             = r.double_attribute("/", "min_fit");
    m.mean_delay          = r.double_attribute("/", "mean_delay_steps");
    m.compression_seconds = r.double_attribute("/", "compression_seconds");
    m.source_file         = r.string_attribute("/", "source_file");
    if (!(m.theta > 0 && m.theta <= 1))
      fail("theta must be in (0, 1]");
    for (const char *name : {"/representatives/waveforms", "/representatives/first",
                             "/representatives/term_representative",
                             "/representatives/term_delay", "/representatives/term_amplitude"})
      if (!r.exists(name))
        fail("missing dataset '" + std::string(name) + "'");
    const auto first = r.read_int("/representatives/first", {m.n_inputs + 1ull});
    const long long max_reps = static_cast<long long>(m.n_inputs) * m.n_outputs;
    for (size_t k = 0; k < first.size(); ++k)
      if (first[k] < 0 || first[k] > max_reps || (k > 0 && first[k] <= first[k - 1]) ||
          (k == 0 && first[k] != 0))
        fail("representatives/first must increase from 0 to at most inputs x outputs (every "
             "input keeps at least one representative)");
    m.first_representative.assign(first.begin(), first.end());
    const hsize_t R = m.first_representative.back();
    m.representatives = r.read_float("/representatives/waveforms", {R, m.length});
    const std::vector<hsize_t> terms = {m.n_inputs, m.n_outputs, m.blend};
    const auto rep   = r.read_int("/representatives/term_representative", terms);
    const auto delay = r.read_int("/representatives/term_delay", terms);
    m.term_amplitude = r.read_float("/representatives/term_amplitude", terms);
    m.term_representative.resize(rep.size());
    m.term_delay.resize(delay.size());
    // Every slot is checked, amplitude 0 or not: the runtime reads them all.
    for (size_t t = 0; t < rep.size(); ++t)
      {
        const size_t k   = t / (static_cast<size_t>(m.n_outputs) * m.blend);
        const auto   n_k = m.first_representative[k + 1] - m.first_representative[k];
        if (rep[t] < 0 || static_cast<std::uint64_t>(rep[t]) >= n_k || delay[t] < 0 ||
            delay[t] > m.delay_span)
          fail("blend term " + std::to_string(t) + " refers to a representative or delay out of "
               "range");
        if (!std::isfinite(m.term_amplitude[t]))
          fail("term_amplitude contains NaN or Inf");
        m.term_representative[t] = static_cast<std::uint32_t>(rep[t]);
        m.term_delay[t]          = static_cast<std::uint16_t>(delay[t]);
      }
    for (const float x : m.representatives)
      if (!std::isfinite(x))
        fail("representative waveforms contain NaN or Inf");
    m.n_substituted    = static_cast<std::uint64_t>(m.n_inputs) * m.n_outputs - R;
    return m;
  }
} // namespace irdm
