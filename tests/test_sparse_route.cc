// The sparse modal route of the precompute (the lowest modes by block Lanczos plus residual modes of
// the inputs), against the dense route's all-modes model on the small beam, where both exist.
#include <irdm/modal_model.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>

#include "irdm_test_util.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

using namespace irdm_test;

namespace
{
  // The dense generalized eigenproblem of the free system, ascending.
  struct DenseModes
  {
    Eigen::VectorXd w2;
    Eigen::MatrixXd phi, k_inverse;
  };

  DenseModes
  dense_modes(const fem::DenseSystem &sys)
  {
    const Eigen::Index n = sys.n_free;
    Eigen::MatrixXd    K = Eigen::Map<const Eigen::MatrixXd>(sys.stiffness.data(), n, n);
    Eigen::MatrixXd    M = Eigen::Map<const Eigen::MatrixXd>(sys.mass.data(), n, n);
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(K, M);
    return {es.eigenvalues(), es.eigenvectors(), K.ldlt().solve(Eigen::MatrixXd::Identity(n, n))};
  }

  double
  relative_difference(const ImpulseResponseModel &a, const ImpulseResponseModel &b)
  {
    double d = 0, norm = 0;
    for (size_t i = 0; i < a.h_double.size(); ++i)
      {
        d += std::pow(a.h_double[i] - b.h_double[i], 2);
        norm += std::pow(b.h_double[i], 2);
      }
    return std::sqrt(d / norm);
  }
} // namespace

TEST(SparseRoute, LowestModesAndStaticComplianceEqualTheDenseSolution)
{
  const fem::Scene        scene = fem::parse_scene(beam_scene(""), ".");
  const fem::ElasticDynamics fem(scene);
  const fem::DenseSystem  sys = fem.dense_free_system();
  const DenseModes        dense = dense_modes(sys);
  std::vector<int>        rows, columns;
  for (int i = 3; i < static_cast<int>(sys.n_free); i += 41)
    columns.push_back(i);
  rows = columns; // the columns first: the basis' compliance at (columns, columns) is checked
  for (int i = 0; i < static_cast<int>(sys.n_free); i += 7)
    rows.push_back(i);
  const unsigned          count = 40;
  const fem::LowestModes  lm    = fem.lowest_modes(count, rows, columns);
  const unsigned total = static_cast<unsigned>(lm.w2.size());
  ASSERT_EQ(lm.n_lowest, count);
  ASSERT_EQ(total, count + columns.size()); // one residual mode per load column
  // A dense eigensolver's error is about eps * w2_max, so its lowest w2 are relatively the
  // least accurate (measured: 3e-9 for the first): agreement to 1e-7.
  for (unsigned i = 0; i < count; ++i)
    EXPECT_NEAR(lm.w2[i] / dense.w2[i], 1.0, 1e-7) << "mode " << i;
  EXPECT_LT(lm.largest_residual, 1e-8);
  double worst = 0, scale = 0;
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t c = 0; c < columns.size(); ++c)
      {
        worst = std::max(worst, std::abs(lm.compliance[r * columns.size() + c] -
                                         dense.k_inverse(rows[r], columns[c])));
        scale = std::max(scale, std::abs(dense.k_inverse(rows[r], columns[c])));
      }
  // cond(K) is about 1e7 here: the dense inverse itself carries ~1e-10 of relative error.
  EXPECT_LT(worst, 1e-9 * scale);
  // The basis (lowest + residual modes) holds K^-1 at the load columns exactly:
  // sum_i phi_i(a) phi_i(b) / w2_i = (K^-1)(a, b) for columns a, b.
  double basis_worst = 0;
  for (size_t a = 0; a < columns.size(); ++a)
    for (size_t c = 0; c < columns.size(); ++c)
      {
        double sum = 0;
        for (unsigned i = 0; i < total; ++i)
          sum += lm.shapes[a * total + i] * lm.shapes[c * total + i] / lm.w2[i];
        basis_worst = std::max(basis_worst, std::abs(sum - dense.k_inverse(columns[a], columns[c])));
      }
  EXPECT_LT(basis_worst, 1e-9 * scale);
  // Without the residual modes it is not (the lowest 40 carry only part of it).
  double lowest_worst = 0;
  for (size_t a = 0; a < columns.size(); ++a)
    {
      double sum = 0;
      for (unsigned i = 0; i < count; ++i)
        sum += lm.shapes[a * total + i] * lm.shapes[a * total + i] / lm.w2[i];
      lowest_worst = std::max(lowest_worst, std::abs(sum / dense.k_inverse(columns[a], columns[a]) - 1));
    }
  EXPECT_GT(lowest_worst, 1e-3);
  // With a step shift sigma the basis also holds (K + sigma M)^-1 at the load columns (the
  // time step's K_eff up to a factor), and still K^-1. sigma here: the shift of a 2 ms step
  // with beta = 1/4, 1 / (beta dt^2), well inside the spectrum the lowest modes miss.
  const double           sigma   = 1 / (0.25 * 0.002 * 0.002);
  const fem::LowestModes shifted = fem.lowest_modes(count, rows, columns, sigma);
  const unsigned         total_s = static_cast<unsigned>(shifted.w2.size());
  EXPECT_GT(total_s, total);
  EXPECT_LE(total_s, count + 2 * columns.size());
  const Eigen::MatrixXd Kd = Eigen::Map<const Eigen::MatrixXd>(sys.stiffness.data(), sys.n_free, sys.n_free);
  const Eigen::MatrixXd Md = Eigen::Map<const Eigen::MatrixXd>(sys.mass.data(), sys.n_free, sys.n_free);
  const Eigen::MatrixXd step_inverse =
    (Kd + sigma * Md).ldlt().solve(Eigen::MatrixXd::Identity(sys.n_free, sys.n_free));
  double step_worst = 0, step_scale = 0, static_worst = 0, unshifted_step_worst = 0;
  for (size_t a = 0; a < columns.size(); ++a)
    for (size_t c = 0; c < columns.size(); ++c)
      {
        double step_sum = 0, static_sum = 0, unshifted = 0;
        for (unsigned i = 0; i < total_s; ++i)
          {
            const double pp = shifted.shapes[a * total_s + i] * shifted.shapes[c * total_s + i];
            step_sum += pp / (shifted.w2[i] + sigma);
            static_sum += pp / shifted.w2[i];
          }
        for (unsigned i = 0; i < total; ++i)
          unshifted += lm.shapes[a * total + i] * lm.shapes[c * total + i] / (lm.w2[i] + sigma);
        const double exact = step_inverse(columns[a], columns[c]);
        step_worst = std::max(step_worst, std::abs(step_sum - exact));
        unshifted_step_worst = std::max(unshifted_step_worst, std::abs(unshifted - exact));
        step_scale = std::max(step_scale, std::abs(exact));
        static_worst = std::max(static_worst, std::abs(static_sum - dense.k_inverse(columns[a], columns[c])));
      }
  std::printf("step compliance at the columns: error %.2e with the step's residual modes, %.2e "
              "with the static ones alone (of %.2e)\n", step_worst, unshifted_step_worst, step_scale);
  EXPECT_LT(step_worst, 1e-9 * step_scale);
  EXPECT_LT(static_worst, 1e-9 * scale);
  EXPECT_GT(unshifted_step_worst, 1e-4 * step_scale); // what the static residual modes alone miss
  // Each mode's shape at the rows equals the dense one up to its sign (the beam's lowest 40
  // modes are simple here: no two eigenvalues within 1e-6 of each other).
  for (unsigned i = 0; i < count; ++i)
    {
      ASSERT_GT(dense.w2[i + 1] / dense.w2[i] - 1, 1e-6) << "mode " << i << " is degenerate";
      double dot = 0;
      for (size_t r = 0; r < rows.size(); ++r)
        dot += lm.shapes[r * total + i] * dense.phi(rows[r], i);
      const double sign = dot < 0 ? -1 : 1;
      double       diff = 0, norm = 0;
      for (size_t r = 0; r < rows.size(); ++r)
        {
          diff = std::max(diff, std::abs(lm.shapes[r * total + i] - sign * dense.phi(rows[r], i)));
          norm = std::max(norm, std::abs(dense.phi(rows[r], i)));
        }
      EXPECT_LT(diff, 1e-6 * norm) << "mode " << i;
    }
}

TEST(SparseRoute, TruncatedModelConvergesToTheAllModesModelAndKeepsItsStaticCompliance)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       all   = make_model(scene, "sparse_all.h5");
  double           previous = 1e300;
  for (const unsigned modes : {25u, 50u, 100u, 200u, 400u})
    {
      fem::PrecomputeOptions o;
      o.output  = tmp("sparse_" + std::to_string(modes) + ".h5");
      o.restart = true;
      o.modes   = modes;
      const auto rep = fem::precompute_impulse_responses(scene, o);
      EXPECT_TRUE(rep.sparse);
      EXPECT_EQ(rep.n_lowest, modes);
      // Two residual modes per input DoF (static and one-step responses), less those the
      // basis already spans (at 400 of 540).
      EXPECT_LE(rep.n_modes, std::min(modes + 2 * all.n_inputs, rep.n_free));
      EXPECT_GT(rep.n_modes, modes);
      EXPECT_LT(rep.static_basis_error_max, 1e-9);
      const auto model = load_model(o.output, scene.time_step);
      ASSERT_EQ(model.h_double.size(), all.h_double.size());
      ASSERT_EQ(model.modes.n_modes, rep.n_modes);
      const double error = relative_difference(model, all);
      // Driving-point static compliance over the model's length: the modes left out are fast
      // and decay within T in the all-modes model, so the sums agree to their tails.
      double static_worst = 0;
      for (unsigned k = 0; k < model.n_inputs; ++k)
        {
          const unsigned kk = 3 * model.input_output_index[k / 3] + k % 3;
          double         a = 0, b = 0;
          for (unsigned s = 0; s < model.length; ++s)
            a += model.h(k, s, kk), b += all.h(k, s, kk);
          static_worst = std::max(static_worst, std::abs(a / b - 1));
        }
      // The feed-through H[0] (what a probe that prescribes a displacement inverts): exact at
      // every output for loads at the inputs, whatever the number of modes.
      double feed_worst = 0, feed_scale = 0;
      for (unsigned k = 0; k < model.n_inputs; ++k)
        for (unsigned j = 0; j < model.n_outputs; ++j)
          {
            feed_worst = std::max(feed_worst, std::abs(model.h(k, 0, j) - all.h(k, 0, j)));
            feed_scale = std::max(feed_scale, std::abs(all.h(k, 0, j)));
          }
      std::printf("%u of %u modes + %u residual: H relative error %.3e, driving-point static "
                  "compliance %.1e, feed-through %.1e; lowest modes alone carry %.4f of the "
                  "static compliance (least)\n",
                  modes, rep.n_free, rep.n_modes - modes, error, static_worst,
                  feed_worst / feed_scale, rep.static_in_modes_min);
      EXPECT_LT(error, previous);
      EXPECT_LT(static_worst, 1e-6);
      EXPECT_LT(feed_worst, 1e-9 * feed_scale);
      previous = error;
    }
}

// A sampled input set (validate --full-model-stride): every k-th input vertex plus a region
// kept whole. Each input's responses do not depend on which other inputs are in the model, so
// the sample's H equals the full model's at the same inputs.
TEST(InputSample, EveryKthInputPlusTheKeptRegionWithTheFullModelsResponses)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       all   = make_model(scene, "sample_all.h5");
  fem::PrecomputeOptions o;
  o.output        = tmp("sample_3.h5");
  o.restart       = true;
  o.input_stride  = 3;
  o.inputs_always = fem::VertexRegion{{}, {{{0.24, 0.0, 0.01}, 0.012}}};
  fem::precompute_impulse_responses(scene, o);
  const auto sample = load_model(o.output, scene.time_step);
  ASSERT_EQ(sample.n_outputs, all.n_outputs);
  // The expected set: every 3rd input vertex in order, plus those within the kept ball.
  std::vector<long long> expected;
  unsigned               kept = 0;
  for (size_t i = 0; i < all.input_node_tags.size(); ++i)
    {
      const auto  &x     = all.output_coordinates[all.input_output_index[i]];
      const double d2    = std::pow(x[0] - 0.24, 2) + std::pow(x[1], 2) + std::pow(x[2] - 0.01, 2);
      const bool   in_ball = d2 <= 0.012 * 0.012;
      kept += in_ball && i % 3 != 0;
      if (i % 3 == 0 || in_ball)
        expected.push_back(all.input_node_tags[i]);
    }
  ASSERT_GT(kept, 0u) << "the kept ball adds no vertex: the test would not test it";
  ASSERT_EQ(sample.input_node_tags, expected);
  double worst = 0, scale = 0;
  for (unsigned k = 0; k < sample.n_inputs; ++k)
    {
      const auto   it = std::find(all.input_node_tags.begin(), all.input_node_tags.end(),
                                  sample.input_node_tags[k / 3]);
      const unsigned ka = 3 * static_cast<unsigned>(it - all.input_node_tags.begin()) + k % 3;
      for (unsigned s = 0; s < sample.length; ++s)
        for (unsigned j = 0; j < sample.n_outputs; ++j)
          {
            worst = std::max(worst, std::abs(sample.h(k, s, j) - all.h(ka, s, j)));
            scale = std::max(scale, std::abs(all.h(ka, s, j)));
          }
    }
  EXPECT_LT(worst, 1e-12 * scale);
}

// A model written without H (--modal-only, format version 3): only the modal runtime reads it,
// from the modes alone; its feed-through and static correction equal those make_modal_model
// takes from the stored H (the sparse route, fixed beam; and a free body's rigid-fit route,
// whose load shapes differ from its response shapes).
TEST(ModalOnly, TheModalModelFromTheModesAloneEqualsTheOneFromH)
{
  struct Case
  {
    std::string            name;
    fem::Scene             scene;
    fem::PrecomputeOptions options;
  };
  std::vector<Case> cases(2);
  cases[0].name          = "sparse_fixed";
  cases[0].scene         = fem::parse_scene(beam_scene(""), ".");
  cases[0].options.modes = 50;
  cases[1].name          = "rigid_fit_free";
  cases[1].scene         = fem::parse_scene(beam_scene(""), ".");
  cases[1].scene.fixed_surfaces.clear();
  cases[1].options.length     = 60;
  cases[1].options.free_route = fem::FreeBodyRoute::rigid_fit;
  for (auto &c : cases)
    {
      SCOPED_TRACE(c.name);
      fem::PrecomputeOptions o = c.options;
      o.restart                = true;
      o.output                 = tmp("modal_only_ref_" + c.name + ".h5");
      fem::precompute_impulse_responses(c.scene, o);
      const ImpulseResponseModel with_h = load_model(o.output, c.scene.time_step);
      o.output     = tmp("modal_only_" + c.name + ".h5");
      o.modal_only = true;
      const auto rep = fem::precompute_impulse_responses(c.scene, o);
      EXPECT_TRUE(rep.modal_only);
      EXPECT_EQ(rep.bytes, 0);
      {
        const h5::Reader r(o.output);
        EXPECT_FALSE(r.exists("/impulse_response/H"));
        EXPECT_EQ(r.double_attribute("/", "format_version"), 3);
      }
      EXPECT_LT(fs::file_size(o.output), fs::file_size(tmp("modal_only_ref_" + c.name + ".h5")) / 2);
      // A use that needs H refuses the file, naming why.
      try
        {
          load_model(o.output, c.scene.time_step);
          ADD_FAILURE() << "a modal-only model loaded as if it held H";
        }
      catch (const InputError &e)
        {
          EXPECT_NE(std::string(e.what()).find("--modal-only"), std::string::npos) << e.what();
        }
      const ImpulseResponseModel modes_only =
        load_model(o.output, c.scene.time_step, ModelParts::modal_realization);
      EXPECT_TRUE(modes_only.modal_only);
      EXPECT_TRUE(modes_only.h_double.empty() && modes_only.h_float.empty());
      ASSERT_EQ(modes_only.modes.n_modes, with_h.modes.n_modes);
      const unsigned N = with_h.modes.n_modes;
      // Every mode in the force loop, and the lowest 40 with the rest quasi-static.
      for (const unsigned force_modes : {0u, 40u})
        {
          const ModalModelOptions mo{20, force_modes};
          const ModalModel        a = make_modal_model(with_h, mo), b = make_modal_model(modes_only, mo);
          ASSERT_EQ(a.h0_inputs.size(), b.h0_inputs.size());
          ASSERT_EQ(a.residual.size(), b.residual.size());
          double h0_scale = 0, h0_diff = 0, e_scale = 0, e_diff = 0;
          for (size_t i = 0; i < a.h0_inputs.size(); ++i)
            {
              h0_scale = std::max(h0_scale, std::abs(a.h0_inputs[i]));
              h0_diff  = std::max(h0_diff, std::abs(a.h0_inputs[i] - b.h0_inputs[i]));
            }
          for (size_t i = 0; i < a.residual.size(); ++i)
            {
              e_scale = std::max(e_scale, std::abs(double(a.residual[i])));
              e_diff  = std::max(e_diff, std::abs(double(a.residual[i]) - b.residual[i]));
            }
          std::printf("%s, %u modes, force loop %u: feed-through differs by %.2e, static "
                      "correction by %.2e of its largest entry\n",
                      c.name.c_str(), N, force_modes == 0 ? N : force_modes, h0_diff / h0_scale,
                      e_diff / e_scale);
          // H in double is the modal sum to a tenth of its round-off (the precompute's live
          // modes): the feed-through agrees to round-off; E is stored in float.
          EXPECT_LT(h0_diff, 1e-12 * h0_scale);
          EXPECT_GT(e_scale, 0);
          EXPECT_LT(e_diff, 1e-6 * e_scale);
          EXPECT_EQ(a.input_shapes, b.input_shapes);
          EXPECT_EQ(a.shapes, b.shapes);
        }
    }
}
