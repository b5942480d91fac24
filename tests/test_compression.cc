// Compression by representative waveforms: every substituted waveform meets its bound
// (relative L2 error <= sqrt(1 - theta^2)); the compressed runtime equals direct convolution of
// the tensor the compressed model stands for; HDF5 round trip and bad input.
#include <irdm/irdm.h>
#include <irdm/modal_model.h>
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm/response_exchange.h>
#include <irdm/state_space_interaction.h>
#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <irdm_common/h5.h>

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

#include "irdm_test_util.h"

using namespace irdm;
using namespace irdm_test;

namespace
{
  // The tensor a compressed model stands for, as an ordinary model (T + delay span samples).
  ImpulseResponseModel
  decompress(const RepresentativeModel &c)
  {
    ImpulseResponseModel m;
    static_cast<ModelFrame &>(m) = c;
    m.length         = c.length + c.delay_span;
    m.double_storage = true;
    m.h_double.resize(static_cast<size_t>(m.n_inputs) * m.length * m.n_outputs);
    for (unsigned k = 0; k < m.n_inputs; ++k)
      for (unsigned s = 0; s < m.length; ++s)
        for (unsigned j = 0; j < m.n_outputs; ++j)
          m.h_double[(static_cast<size_t>(k) * m.length + s) * m.n_outputs + j] = c.response(k, s, j);
    return m;
  }

  // Drives a reference runtime and a tested one through the scene's probe (on the "sides"
  // surface) side by side; the tested one's step and surface update run with the allocation
  // counter armed. Returns the largest force and surface differences relative to the
  // reference's peaks, and the reference's peak force.
  struct Difference
  {
    double force = 0, surface = 0, peak_force = 0;
    bool   stepped = true;
  };

  template <class Reference, class Tested>
  Difference
  run_side_by_side(const fem::Scene &scene, const ModelFrame &model, Reference &reference,
                   Tested &tested)
  {
    std::vector<unsigned>                 cand;
    std::vector<std::array<unsigned, 3>> tris;
    for (unsigned t = 0; t < model.triangles.size(); ++t)
      if (model.surface_names[model.triangle_surface[t]] == "sides")
        cand.push_back(t), tris.push_back(model.triangles[t]);
    std::vector<double> ur(model.n_outputs), ut(model.n_outputs);
    double      fmax = 0, ferr = 0, umax = 0, uerr = 0;
    Difference  out;
    const auto &p = scene.probes[0];
    for (unsigned n = 0; n < scene.n_steps(); ++n)
      {
        const double t  = (n + 1) * scene.time_step;
        const auto   sp = geometry::closest_point(model.output_coordinates, tris, p.path.at(t));
        ProbeTarget  target;
        target.triangle = static_cast<int>(cand[sp.triangle]);
        target.weights  = sp.weights;
        for (int d = 0; d < 3; ++d)
          target.displacement[d] = p.depth.at(t) * p.direction[d];
        target.present = t <= p.until;
        out.stepped    = out.stepped && reference.step(&target, 1);
        reference.surface_displacement(ur.data());
        g_count_allocations = true;
        out.stepped         = tested.step(&target, 1) && out.stepped;
        tested.surface_displacement(ut.data());
        g_count_allocations = false;
        for (int d = 0; d < 3; ++d)
          {
            fmax = std::max(fmax, std::abs(reference.force(0)[d]));
            ferr = std::max(ferr, std::abs(reference.force(0)[d] - tested.force(0)[d]));
          }
        for (unsigned j = 0; j < model.n_outputs; ++j)
          {
            umax = std::max(umax, std::abs(ur[j]));
            uerr = std::max(uerr, std::abs(ur[j] - ut[j]));
          }
      }
    out.force      = ferr / fmax;
    out.surface    = uerr / umax;
    out.peak_force = fmax;
    return out;
  }
} // namespace

TEST(Compression, EverySubstitutedWaveformMeetsItsThreshold)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       model = make_model(scene, "compress_src.h5");
  for (const unsigned blend : {1u, 2u})
    for (const double theta : {0.8, 0.95})
      {
        CompressionOptions o;
        o.theta = theta;
        o.blend = blend;
        const auto c = compress(model, o);
        EXPECT_EQ(c.n_representative() + c.n_substituted,
                  static_cast<std::uint64_t>(model.n_inputs) * model.n_outputs);
        EXPECT_GT(c.n_substituted, 0u);
        EXPECT_GE(c.min_fit, theta);
        // Substituted waveforms: |w - w_hat| / |w| <= sqrt(1 - theta^2) (float round-off);
        // representatives: exact to float.
        double worst = 0, worst_rep = 0;
        for (unsigned k = 0; k < model.n_inputs; ++k)
          for (unsigned j = 0; j < model.n_outputs; ++j)
            {
              double e2 = 0, w2 = 0;
              for (unsigned s = 0; s < model.length; ++s)
                {
                  const double w = model.h(k, s, j);
                  e2 += std::pow(w - c.response(k, s, j), 2);
                  w2 += w * w;
                }
              const size_t t = (static_cast<size_t>(k) * model.n_outputs + j) * blend;
              const bool is_rep = c.term_amplitude[t] == 1.0f && c.term_delay[t] == 0 &&
                                  (blend == 1 || c.term_amplitude[t + 1] == 0);
              (is_rep ? worst_rep : worst) = std::max(is_rep ? worst_rep : worst, std::sqrt(e2 / w2));
            }
        EXPECT_LE(worst, std::sqrt(1 - theta * theta) + 1e-5) << "blend " << blend;
        EXPECT_GT(worst, 0.1 * std::sqrt(1 - theta * theta)); // the threshold is used, not idle
        EXPECT_LT(worst_rep, 1e-6);
      }
}

TEST(Compression, RuntimeEqualsDirectConvolutionOfTheCompressedTensor)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(beam_probe), ".");
  const auto       model = make_model(scene, "compress_run.h5");
  for (const unsigned blend : {1u, 3u})
    {
      CompressionOptions o;
      o.theta = 0.9;
      o.blend = blend;
      const auto c = compress(model, o);
      ASSERT_GT(c.delay_span, 0u) << "the test must exercise delayed reads";
      const auto full = decompress(c);

      PointInteraction          direct(full);
      RepresentativeInteraction compressed(c);
      const Difference          diff = run_side_by_side(scene, model, direct, compressed);
      ASSERT_TRUE(diff.stepped);
      EXPECT_EQ(g_allocations, 0) << "heap allocations inside step() / surface_displacement()";
      EXPECT_GT(diff.peak_force, 1e-4);
      EXPECT_LT(diff.force, 1e-10) << "blend " << blend;
      EXPECT_LT(diff.surface, 1e-10) << "blend " << blend;
    }
}

TEST(Compression, FileRoundTripAndBadInput)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       model = make_model(scene, "compress_io.h5");
  CompressionOptions o;
  o.theta = 0.85;
  o.blend = 2;
  const auto c = compress(model, o);
  save_representative_model(c, tmp("compress_io.h5"), tmp("compressed.h5"));
  const auto back = load_representative_model(tmp("compressed.h5"), 0.002);
  EXPECT_EQ(back.n_representative(), c.n_representative());
  EXPECT_EQ(back.representatives, c.representatives);
  EXPECT_EQ(back.term_amplitude, c.term_amplitude);
  EXPECT_EQ(back.term_delay, c.term_delay);
  EXPECT_EQ(back.term_representative, c.term_representative);
  EXPECT_EQ(back.triangles, c.triangles);
  EXPECT_DOUBLE_EQ(back.theta, 0.85);
  {
    h5::Reader r(tmp("compressed.h5")); // the source's metadata is carried over
    EXPECT_EQ(r.string_attribute("/", "integrator"), "generalized_alpha");
    EXPECT_TRUE(r.exists("/modes/frequency_Hz"));
  }
  EXPECT_THROW(load_representative_model(tmp("compress_io.h5")), InputError); // not compressed
  EXPECT_THROW(load_representative_model(tmp("compressed.h5"), 0.001), InputError); // step
  o.theta = 1.5;
  EXPECT_THROW(compress(model, o), InputError);
  o.theta = 0.9;
  o.blend = 5;
  EXPECT_THROW(compress(model, o), InputError);
}

// The modal realization: its force loop carries every mode, so the force is the exact model's;
// the surface is exact with every mode and its error falls as surface modes are added.
TEST(Compression, ModalModelConvergesToTheExactModelWithItsModes)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(beam_probe), ".");
  const auto       model = make_model(scene, "modal_compression.h5");
  ASSERT_GT(model.modes.n_modes, 20u);
  std::vector<double> errors;
  for (const unsigned M : {5u, model.modes.n_modes / 4, model.modes.n_modes})
    {
      const auto       modal = make_modal_model(model, {M});
      PointInteraction exact(model);
      ModalInteraction fast(modal);
      const Difference diff = run_side_by_side(scene, model, exact, fast);
      ASSERT_TRUE(diff.stepped);
      EXPECT_EQ(g_allocations, 0);
      EXPECT_LT(diff.force, 1e-9) << "the force loop carries every mode: exact";
      errors.push_back(diff.surface);
    }
  // Every mode: the exact surface up to the single-precision storage of the surface shapes and
  // of E (eps 6e-8), times the cancellation among the modes' contributions (seen: 4e-6).
  EXPECT_LT(errors[2], 2e-5) << "every mode: the exact surface up to float shapes and residual";
  EXPECT_LT(errors[1], errors[0]);
  EXPECT_LT(errors[2], errors[1]);
  EXPECT_GT(errors[0], 1e-3); // 5 surface modes is a real truncation
  EXPECT_THROW(make_modal_model(model, {model.modes.n_modes + 1}), InputError);
}

// The command line: a missing model or a threshold out of range is exit status 2 with a
// message, and a good run writes a model the loader accepts.
TEST(Compression, CommandLineChecksItsInput)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "cli_src.h5");
  const std::string cli = clean_environment() + IRDM_CLI + " compress ";
  const auto status = [](const std::string &cmd) {
    const int s = std::system((cmd + " > /dev/null 2>&1").c_str());
    return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  };
  EXPECT_EQ(status(cli + tmp("missing.h5") + " --out " + tmp("c.h5")), 2);
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("c.h5") + " --theta 1.5"), 2);
  EXPECT_EQ(status(cli + tmp("cli_src.h5")), 2); // no --out
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_c.h5") + " --theta 0.9 --quiet"), 0);
  EXPECT_NO_THROW(load_representative_model(tmp("cli_c.h5"), 0.002));
  // The realization from H alone: a model the runtime's loader takes as kind state_space; an
  // order the Hankel matrix cannot hold is refused with status 2, and no file is left.
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_era.h5") +
                   " --method era --order 20 --quiet"),
            0);
  EXPECT_EQ(load_state_space_model(tmp("cli_era.h5"), 0.002).order, 20u);
  EXPECT_EQ(Model::load(tmp("cli_era.h5")).kind(), "state_space");
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_era_big.h5") +
                   " --method era --order 100000 --quiet"),
            2);
  EXPECT_FALSE(std::filesystem::exists(tmp("cli_era_big.h5")));
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_era_bad.h5") + " --method pca"), 2);
  // --tolerance sizes ERA on a scene: without one, or for representatives, refused.
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_tol.h5") +
                   " --method era --tolerance 0.02"),
            2);
  EXPECT_EQ(status(cli + tmp("cli_src.h5") + " --out " + tmp("cli_tol.h5") + " --tolerance 0.02"),
            2);
  // Export and import: a round trip; an output over the input refused.
  const std::string irdm = clean_environment() + IRDM_CLI;
  EXPECT_EQ(status(irdm + " export " + tmp("cli_src.h5") + " --out " + tmp("cli_x.h5")), 0);
  EXPECT_EQ(status(irdm + " import " + tmp("cli_x.h5") + " --out " + tmp("cli_x.h5")), 2);
  EXPECT_EQ(status(irdm + " import " + tmp("cli_x.h5") + " --out " + tmp("cli_imported.h5")), 0);
  EXPECT_EQ(load_model(tmp("cli_imported.h5")).n_inputs, load_model(tmp("cli_src.h5")).n_inputs);
  EXPECT_EQ(status(irdm + " import " + tmp("cli_src.h5") + " --out " + tmp("cli_y.h5")), 2);
}

// The eigensystem realization from H alone (irdm/state_space_model.h).
namespace
{
  // A frame of n_in / 3 input vertices (the first ones of n_out / 3 output vertices) and the
  // responses of a known stable system of 2 * freq.size() states (complex pairs at radius
  // radius[i] and angle freq[i]): H[0] = D random, H[s] = C A^(s-1) B.
  ImpulseResponseModel
  known_system(const std::vector<double> &radius, const std::vector<double> &angle,
               const unsigned in_vertices, const unsigned out_vertices, const unsigned T)
  {
    ImpulseResponseModel m;
    m.time_step = 0.001;
    m.length    = T;
    m.n_inputs  = 3 * in_vertices;
    m.n_outputs = 3 * out_vertices;
    m.output_coordinates.resize(out_vertices);
    m.output_input_index.assign(out_vertices, -1);
    for (unsigned v = 0; v < in_vertices; ++v)
      m.input_output_index.push_back(v), m.output_input_index[v] = static_cast<int>(v);
    const unsigned  r = 2 * radius.size();
    std::mt19937    rng(7);
    std::normal_distribution<double> normal;
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(r, r), B(r, m.n_inputs), C(m.n_outputs, r),
                    D(m.n_outputs, m.n_inputs);
    for (size_t i = 0; i < radius.size(); ++i)
      {
        const double a = radius[i] * std::cos(angle[i]), b = radius[i] * std::sin(angle[i]);
        A.block<2, 2>(2 * i, 2 * i) << a, b, -b, a;
      }
    for (auto *X : {&B, &C, &D})
      for (Eigen::Index i = 0; i < X->size(); ++i)
        X->data()[i] = normal(rng);
    m.h_double.resize(static_cast<size_t>(m.n_inputs) * T * m.n_outputs);
    for (unsigned k = 0; k < m.n_inputs; ++k)
      {
        Eigen::VectorXd x = B.col(k);
        for (unsigned s = 0; s < T; ++s)
          {
            const Eigen::VectorXd u = s == 0 ? Eigen::VectorXd(D.col(k)) : Eigen::VectorXd(C * x);
            if (s > 0)
              x = A * x;
            for (unsigned j = 0; j < m.n_outputs; ++j)
              m.h_double[(static_cast<size_t>(k) * T + s) * m.n_outputs + j] = u[j];
          }
      }
    return m;
  }

  double
  largest_response_difference(const ImpulseResponseModel &m, const StateSpaceModel &ss)
  {
    double err = 0, peak = 0;
    for (unsigned k = 0; k < m.n_inputs; ++k)
      for (unsigned s = 0; s < m.length; ++s)
        for (unsigned j = 0; j < m.n_outputs; ++j)
          {
            peak = std::max(peak, std::abs(m.h(k, s, j)));
            err  = std::max(err, std::abs(m.h(k, s, j) - ss.response(k, s, j)));
          }
    return err / peak;
  }
} // namespace

// Data from a system of order 8 are realized exactly at order 8, with the system's own poles,
// whether or not the responses are first projected onto as many directions as the system
// reaches (8 input directions; the contact rows and 8 more output directions); onto fewer (4
// input directions) they are not.
TEST(Era, RealizesAKnownSystemExactlyFromItsResponses)
{
  const std::vector<double> radius = {0.97, 0.9, 0.8, 0.6}, angle = {0.05, 0.3, 1.1, 2.5};
  const auto m = known_system(radius, angle, 3, 10, 80);
  for (const unsigned directions : {0u, 8u})
    {
      EraOptions o;
      o.order             = 8;
      o.input_directions  = directions;
      o.output_directions = directions ? directions : 1000;
      const StateSpaceModel ss = identify_era(m, o);
      EXPECT_EQ(ss.order, 8u);
      EXPECT_EQ(ss.n_real, 0u);
      EXPECT_EQ(ss.poles_pulled_in, 0u);
      // C is stored in float: the responses to its rounding (the poles are double).
      EXPECT_LT(largest_response_difference(m, ss), 1e-6) << "directions " << directions;
      std::vector<double> found, expected = radius;
      for (unsigned p = 0; p < ss.n_pairs(); ++p)
        found.push_back(std::hypot(ss.complex_poles[2 * p], ss.complex_poles[2 * p + 1]));
      std::sort(found.begin(), found.end());
      std::sort(expected.begin(), expected.end());
      for (size_t i = 0; i < expected.size(); ++i)
        EXPECT_NEAR(found[i], expected[i], 1e-10);
      EXPECT_LT(ss.hankel_singular_values[8], 1e-10 * ss.hankel_singular_values[0]);
    }
  EraOptions few;
  few.order            = 8;
  few.input_directions = 4;
  EXPECT_GT(largest_response_difference(m, identify_era(m, few)), 1e-3);
  few.order = 0;
  EXPECT_THROW(identify_era(m, few), InputError);
}

// A growing mode in the data (a pole at 1.02) comes out on the stability radius, counted;
// every other pole stays where it was.
TEST(Era, EveryPoleOfTheRealizationIsInsideTheUnitCircle)
{
  const auto m = known_system({1.02, 0.9}, {0.2, 0.7}, 2, 3, 60);
  EraOptions o;
  o.order            = 4;
  o.stability_radius = 0.999;
  const StateSpaceModel ss = identify_era(m, o);
  EXPECT_EQ(ss.poles_pulled_in, 2u); // the pair
  for (unsigned p = 0; p < ss.n_pairs(); ++p)
    EXPECT_LE(std::hypot(ss.complex_poles[2 * p], ss.complex_poles[2 * p + 1]), 0.999 + 1e-15);
  for (const double z : ss.real_poles)
    EXPECT_LT(std::abs(z), 0.999 + 1e-15);
}

// On the beam's FEM model (every input kept) the realization converges to the exact model in
// closed loop as its order grows, a rigid probe's force included (the hardest measure: the
// probe divides the history's error by the small feed-through); its step and surface update
// allocate nothing; a file round trip keeps it, and the loader refuses what the runtime could
// not run.
TEST(Era, ClosedLoopConvergesToTheExactModelWithTheOrder)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(beam_probe), ".");
  const auto       model = make_model(scene, "era_run.h5");
  std::vector<double> force, surface;
  for (const unsigned order : {100u, 300u, 500u})
    {
      EraOptions o;
      o.order = order;
      const StateSpaceModel ss = identify_era(model, o);
      PointInteraction       exact(model);
      StateSpaceInteraction  era(ss);
      const Difference       diff = run_side_by_side(scene, model, exact, era);
      ASSERT_TRUE(diff.stepped);
      EXPECT_EQ(g_allocations, 0) << "heap allocations inside step() / surface_displacement()";
      force.push_back(diff.force);
      surface.push_back(diff.surface);
    }
  EXPECT_LT(force[1], force[0]);
  EXPECT_LT(force[2], force[1]);
  EXPECT_LT(surface[2], surface[0]);
  EXPECT_GT(force[0], 0.05); // order 100 is a real truncation
  EXPECT_LT(force[2], 1e-4);
  EXPECT_LT(surface[2], 1e-4);

  EraOptions o;
  o.order = 40;
  const StateSpaceModel ss = identify_era(model, o);
  save_state_space_model(ss, tmp("era_run.h5"), tmp("era.h5"));
  const StateSpaceModel back = load_state_space_model(tmp("era.h5"), scene.time_step);
  EXPECT_EQ(back.real_poles, ss.real_poles);
  EXPECT_EQ(back.complex_poles, ss.complex_poles);
  EXPECT_EQ(back.b, ss.b);
  EXPECT_EQ(back.c, ss.c);
  EXPECT_FALSE(ss.output_basis.empty()); // the beam's outputs are projected
  EXPECT_EQ(back.output_basis, ss.output_basis);
  EXPECT_EQ(back.contact_direction, ss.contact_direction);
  EXPECT_EQ(back.d, ss.d);
  EXPECT_EQ(back.triangles, ss.triangles);
  EXPECT_THROW(load_state_space_model(tmp("era_run.h5")), InputError); // not a realization
  EXPECT_THROW(load_state_space_model(tmp("era.h5"), 2 * scene.time_step), InputError);
  // The public API runs the file as kind state_space: a probe's force is the interaction's;
  // planes step; an applied force is refused with a reason.
  const irdm::Model api = irdm::Model::load(tmp("era.h5"));
  ASSERT_EQ(api.kind(), "state_space");
  irdm::Body            body(api);
  StateSpaceInteraction direct(back);
  irdm::Probe           probe;
  probe.n_patch           = 1;
  probe.patch_weights[0]  = 1;
  probe.patch_vertices[0] = back.input_output_index[0];
  ProbeTarget target;
  target.n_patch           = 1;
  target.patch_weights[0]  = 1;
  target.patch_vertices[0] = probe.patch_vertices[0];
  irdm::StepInput  in;
  irdm::StepOutput out;
  in.probes   = &probe;
  in.n_probes = 1;
  double largest = 0;
  for (int n = 0; n < 20; ++n)
    {
      probe.displacement = target.displacement = {0, 0, -1e-4 * n};
      g_count_allocations = true;
      ASSERT_TRUE(body.step(in, out)) << body.refusal();
      g_count_allocations = false;
      ASSERT_TRUE(direct.step(&target, 1));
      for (int d = 0; d < 3; ++d)
        EXPECT_EQ(out.probe_force[0][d], direct.force(0)[d]);
      largest = std::max(largest, std::abs(out.probe_force[0][2]));
    }
  EXPECT_EQ(g_allocations, 0);
  EXPECT_GT(largest, 0);
  irdm::Plane far;
  far.point = {0, 0, -10}; // nothing near it
  in.n_probes = 0;
  in.planes   = &far;
  in.n_planes = 1;
  EXPECT_TRUE(body.step(in, out)) << body.refusal();
  irdm::AppliedForce push{probe.patch_vertices[0], {0, 0, -1}};
  in.forces   = &push;
  in.n_forces = 1;
  EXPECT_FALSE(body.step(in, out));
  EXPECT_NE(std::string(body.refusal()).find("applied forces"), std::string::npos) << body.refusal();

  StateSpaceModel unstable = ss;
  unstable.complex_poles[0] *= 1e3; // a pole far outside the unit circle
  save_state_space_model(unstable, tmp("era_run.h5"), tmp("era_unstable.h5"));
  EXPECT_THROW(load_state_space_model(tmp("era_unstable.h5")), InputError);
}


// A model read back from the exchange layout: the same H, frame and triangles, exactly.
void
expect_same_responses(const ImpulseResponseModel &back, const ImpulseResponseModel &model)
{
  ASSERT_EQ(back.length, model.length);
  ASSERT_EQ(back.n_inputs, model.n_inputs);
  ASSERT_EQ(back.n_outputs, model.n_outputs);
  for (unsigned k = 0; k < model.n_inputs; ++k)
    for (unsigned t = 0; t < model.length; ++t)
      for (unsigned j = 0; j < model.n_outputs; ++j)
        ASSERT_EQ(back.h(k, t, j), model.h(k, t, j));
  EXPECT_EQ(back.output_coordinates, model.output_coordinates);
  EXPECT_EQ(back.input_output_index, model.input_output_index);
  EXPECT_EQ(back.triangles, model.triangles);
}

// The exchange layout (irdm export / import): our model out and back in is the same H, the
// same frame and the same closed loop, exactly; responses per unit impulse, inputs matched by
// coordinates and no triangles import as well; bad files are refused naming the field.
TEST(Exchange, ExportThenImportIsTheSameModelExactly)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(beam_probe), ".");
  const auto       model = make_model(scene, "exchange_src.h5");
  export_responses(tmp("exchange_src.h5"), tmp("exchange.h5"));
  const ImportSummary s = import_responses(tmp("exchange.h5"), tmp("imported.h5"));
  EXPECT_FALSE(s.outputs_matched_by_coordinates);
  const auto back = load_model(tmp("imported.h5"), scene.time_step);
  expect_same_responses(back, model);
  EXPECT_EQ(back.modes.n_modes, 0u); // H alone: the direct runtime, compress, ERA
  // The mesh's node tags and the triangles' surfaces come back too: the probe finds its
  // surface by name, and compare-models pairs the two.
  EXPECT_EQ(back.output_node_tags, model.output_node_tags);
  EXPECT_EQ(back.input_node_tags, model.input_node_tags);
  EXPECT_EQ(back.triangle_surface, model.triangle_surface);
  EXPECT_EQ(back.surface_names, model.surface_names);
  PointInteraction original(model), imported(back);
  const Difference diff = run_side_by_side(scene, model, original, imported);
  EXPECT_EQ(diff.force, 0);
  EXPECT_EQ(diff.surface, 0);
  EXPECT_GT(diff.peak_force, 0);

  // Another source's layout: per unit impulse (N s), no output index, no triangles.
  {
    h5::Writer w(tmp("other.h5"));
    w.attribute("/", "format", std::string("irdm-responses"));
    w.attribute("/", "format_version", 1LL);
    w.attribute("/", "time_step_s", model.time_step);
    w.attribute("/", "convention", std::string("unit_impulse"));
    w.attribute("/", "source", std::string("a test"));
    std::vector<double> in_xyz, out_xyz, r(static_cast<size_t>(model.n_inputs) * model.length * model.n_outputs);
    for (const unsigned v : model.input_output_index)
      in_xyz.insert(in_xyz.end(), model.output_coordinates[v].begin(), model.output_coordinates[v].end());
    for (const auto &p : model.output_coordinates)
      out_xyz.insert(out_xyz.end(), p.begin(), p.end());
    for (unsigned k = 0; k < model.n_inputs; ++k)
      for (unsigned t = 0; t < model.length; ++t)
        for (unsigned j = 0; j < model.n_outputs; ++j)
          r[(static_cast<size_t>(k) * model.length + t) * model.n_outputs + j] = model.h(k, t, j) / model.time_step;
    w.create_group("/inputs");
    w.write("/inputs/coordinates", {model.n_inputs / 3, 3}, in_xyz.data());
    w.create_group("/outputs");
    w.write("/outputs/coordinates", {model.n_outputs / 3, 3}, out_xyz.data());
    w.write("/responses", {model.n_inputs, model.length, model.n_outputs}, r.data());
    w.commit();
  }
  const ImportSummary o = import_responses(tmp("other.h5"), tmp("other_model.h5"));
  EXPECT_TRUE(o.outputs_matched_by_coordinates);
  EXPECT_EQ(o.n_triangles, 0u);
  const auto other = load_model(tmp("other_model.h5"));
  EXPECT_EQ(other.input_output_index, model.input_output_index);
  EXPECT_EQ(other.output_node_tags[0], 1); // no tags given: the output vertex number from 1
  double err = 0, peak = 0;
  for (unsigned k = 0; k < model.n_inputs; ++k)
    for (unsigned t = 0; t < model.length; ++t)
      for (unsigned j = 0; j < model.n_outputs; ++j)
        {
          err  = std::max(err, std::abs(other.h(k, t, j) - model.h(k, t, j)));
          peak = std::max(peak, std::abs(model.h(k, t, j)));
        }
  EXPECT_LE(err, 4 * std::numeric_limits<double>::epsilon() * peak); // / tau, then * tau
  EXPECT_EQ(irdm::Model::load(tmp("other_model.h5")).kind(), "direct");

  EXPECT_THROW(import_responses(tmp("exchange_src.h5"), tmp("x.h5")), InputError); // a model
  try
    {
      import_responses(tmp("imported.h5"), tmp("x.h5"));
      ADD_FAILURE() << "a model file imported as responses";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("format"), std::string::npos) << e.what();
    }
}

// The CSV layout of the exchange: our model out as a folder of CSV files and back in is the
// same H, frame and triangles exactly (17 digits read back to the same double); a folder with a
// bad number, a missing row, a row twice or a wrong header is refused naming the file and line,
// and an existing folder is never written into.
TEST(Exchange, CsvExportThenImportIsTheSameModelExactly)
{
  namespace fs     = std::filesystem;
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       model = make_model(scene, "exchange_csv_src.h5");
  const std::string dir  = tmp("exchange_csv");
  fs::remove_all(dir);
  export_responses_csv(tmp("exchange_csv_src.h5"), dir);
  EXPECT_FALSE(fs::exists(dir + ".part"));
  EXPECT_THROW(export_responses_csv(tmp("exchange_csv_src.h5"), dir), InputError);
  const ImportSummary s = import_responses(dir, tmp("exchange_csv_model.h5"));
  EXPECT_FALSE(s.outputs_matched_by_coordinates);
  const auto back = load_model(tmp("exchange_csv_model.h5"), scene.time_step);
  expect_same_responses(back, model);

  // Each corruption of a copy is refused, naming the file (and the line where there is one).
  const auto read = [](const std::string &f) {
    std::ifstream in(f);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string responses = read(dir + "/responses.csv");
  const auto        refused   = [&](const std::string &file, const std::string &text,
                            const std::string &expect) {
    const std::string bad = tmp("exchange_csv_bad");
    fs::remove_all(bad);
    fs::copy(dir, bad);
    std::ofstream(bad + "/" + file) << text;
    try
      {
        import_responses(bad, tmp("exchange_csv_bad.h5"));
        ADD_FAILURE() << "imported: " << expect;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      }
  };
  const size_t second = responses.find('\n', responses.find('\n') + 1) + 1; // after row 1
  refused("responses.csv", responses.substr(0, second), "every input DoF at every sample");
  // The second row (input DoF 0, sample 1) made sample 0, the first row's again.
  std::string  twice  = responses;
  const size_t comma1 = twice.find(',', second);
  const size_t comma2   = twice.find(',', comma1 + 1);
  twice.replace(comma1 + 1, comma2 - comma1 - 1, "0");
  refused("responses.csv", twice, "twice");
  std::string nan = responses;
  nan.replace(nan.find(',', comma2 + 1) + 1, 1, "x");
  refused("responses.csv", nan, "line 3");
  refused("responses.csv", "input_dof,sample,u_0\n", "header");
  refused("outputs.csv", "x_m,y_m,z_m\n0,0\n", "outputs.csv', line 2");
  refused("meta.csv", "key,value\nformat,irdm-responses\nformat_version,1\n", "time_step_s");
  fs::remove(dir + "/inputs.csv");
  EXPECT_THROW(import_responses(dir, tmp("exchange_csv_bad.h5")), InputError);
}

// Balanced truncation of the modal realization (irdm/state_space_model.h): on the beam's FEM
// model (every mode), the truncation to r states misses H by at most twice the sum of the Hankel
// singular values it drops, in the spectral norm at every sample (the discrete-time bound of
// Al-Saggaf and Franklin 1987), the miss falls with r, every pole is inside the unit circle,
// and the file round trip keeps the method.
TEST(Balanced, TruncationMissesHByAtMostTwiceTheDroppedHankelSingularValues)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       model = make_model(scene, "balanced_src.h5");
  const unsigned   n     = 3 * model.modes.n_modes;
  BalancedOptions  o;
  o.order          = 200; // every singular value is computed (3 x the modes is below 4000)
  o.contact_weight = 1;   // the outputs as they are: the bound is on H itself
  const auto g = prepare_balanced(model, o);
  const unsigned nin = model.n_inputs, nout = model.n_outputs, T = model.length;
  double         peak = 0;
  for (unsigned k = 0; k < nin; ++k)
    for (unsigned s = 0; s < T; ++s)
      for (unsigned j = 0; j < nout; ++j)
        peak = std::max(peak, std::abs(model.h(k, s, j)));
  double previous = INFINITY;
  for (const unsigned r : {8u, 24u, 60u, 200u})
    {
      const StateSpaceModel bt = realize_balanced(model, *g, r);
      ASSERT_EQ(bt.order, r);
      double tail = 0;
      for (size_t i = r; i < bt.hankel_singular_values.size(); ++i)
        tail += bt.hankel_singular_values[i];
      // H_r[s] = C A^(s-1) B column by column, A block-diagonal as stored.
      std::vector<Eigen::MatrixXd> E(T, Eigen::MatrixXd::Zero(nout, nin));
      for (unsigned k = 0; k < nin; ++k)
        {
          Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(bt.b.data() + static_cast<size_t>(k) * r, r);
          for (unsigned s = 0; s < T; ++s)
            {
              for (unsigned j = 0; j < nout; ++j)
                {
                  double y = bt.d[static_cast<size_t>(k) * nout + j] * (s == 0);
                  for (unsigned q = 0; s > 0 && q < r; ++q)
                    y += static_cast<double>(bt.c[static_cast<size_t>(j) * r + q]) * x[q];
                  E[s](j, k) = model.h(k, s, j) - y;
                }
              if (s == 0)
                continue;
              Eigen::VectorXd next(r);
              for (unsigned q = 0; q < bt.n_real; ++q)
                next[q] = bt.real_poles[q] * x[q];
              for (unsigned p = 0; p < bt.n_pairs(); ++p)
                {
                  const unsigned q = bt.n_real + 2 * p;
                  const double   a = bt.complex_poles[2 * p], b = bt.complex_poles[2 * p + 1];
                  next[q]     = a * x[q] + b * x[q + 1];
                  next[q + 1] = -b * x[q] + a * x[q + 1];
                }
              x = next;
            }
        }
      double worst = 0;
      for (unsigned s = 0; s < T; ++s)
        worst = std::max(worst, Eigen::JacobiSVD<Eigen::MatrixXd>(E[s]).singularValues()(0));
      // C is stored in float: its rounding (6e-8 of H's scale) is allowed beside the bound.
      EXPECT_LE(worst, 2 * tail + 1e-6 * peak) << "r = " << r;
      EXPECT_GT(worst, 1e-3 * 2 * tail) << "r = " << r << ": the bound is not met by a miss this small";
      EXPECT_LT(worst, previous);
      previous = worst;
      for (const double z : bt.real_poles)
        EXPECT_LT(std::abs(z), 1);
      for (unsigned p = 0; p < bt.n_pairs(); ++p)
        EXPECT_LT(std::hypot(bt.complex_poles[2 * p], bt.complex_poles[2 * p + 1]), 1);
    }
  const StateSpaceModel bt = realize_balanced(model, *g, 24);
  save_state_space_model(bt, tmp("balanced_src.h5"), tmp("balanced.h5"));
  EXPECT_EQ(load_state_space_model(tmp("balanced.h5")).method, "balanced_truncation");
  EXPECT_TRUE(bt.singular_values_complete);
  EXPECT_LE(bt.hankel_singular_values.size(), n);
  EXPECT_THROW(realize_balanced(model, *g, 201), InputError);
}
