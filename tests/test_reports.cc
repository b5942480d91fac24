// Report templates (irdm_common/report_template.h): values, sections, and the errors that
// keep a template and its writer in step; every template of the project fills. The error
// measures every study reports (validation/src/metrics.h).
#include "metrics.h"
#include "nonlinear_map.h"
#include <irdm_common/error.h>
#include <irdm_common/report_template.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <stdexcept>

using irdm::fill_template;
using irdm::TemplateValues;

TEST(ReportTemplate, ValuesAndSectionsAreFilled)
{
  const std::string text = "a {{x}} b{{#on}} [on {{x}}]{{/on}}{{^on}} [off]{{/on}}"
                           "{{#off}} hidden {{y}}{{/off}}{{^off}} shown{{/off}}.";
  EXPECT_EQ(fill_template(text, {{"x", "1.5"}, {"on", "1"}, {"off", ""}, {"y", "2"}}),
            "a 1.5 b [on 1.5] shown.");
  EXPECT_EQ(fill_template(text, {{"x", "0"}, {"on", "0"}, {"off", ""}, {"y", "2"}}),
            "a 0 b [off] shown.");
  // Nested sections, and a section whose value is also printed.
  EXPECT_EQ(fill_template("{{#k}}k = {{k}}{{#n}}, n{{/n}}{{/k}}|", {{"k", "300"}, {"n", "1"}}),
            "k = 300, n|");
  EXPECT_EQ(fill_template("{{#k}}k = {{k}}{{#n}}, n{{/n}}{{/k}}|", {{"k", ""}, {"n", "1"}}), "|");
}

TEST(ReportTemplate, ATemplateAndItsValuesMustAgree)
{
  EXPECT_THROW(fill_template("{{missing}}", {}), std::logic_error);
  EXPECT_THROW(fill_template("text", {{"unused", "1"}}), std::logic_error);
  EXPECT_THROW(fill_template("{{#s}} open", {{"s", "1"}}), std::logic_error);
  EXPECT_THROW(fill_template("{{/s}}", {{"s", "1"}}), std::logic_error);
  EXPECT_THROW(fill_template("{{#s}}{{/t}}", {{"s", "1"}, {"t", "1"}}), std::logic_error);
  EXPECT_THROW(fill_template("{{s", {{"s", "1"}}), std::logic_error);
}

TEST(ReportTemplate, EveryTemplateOfTheProjectFills)
{
  const std::regex tag(R"(\{\{[#^/]?([a-z_0-9]+)\}\})");
  int              n = 0;
  for (const std::string folder : {"validation/templates", "apps/templates"})
    for (const auto &f : std::filesystem::directory_iterator(IRDM_SOURCE_DIR "/" + folder))
      {
        SCOPED_TRACE(f.path().string());
        const std::string text = irdm::read_template(folder + "/" + f.path().filename().string());
        TemplateValues    v;
        for (std::sregex_iterator i(text.begin(), text.end(), tag), end; i != end; ++i)
          v[(*i)[1]] = "1";
        ASSERT_FALSE(v.empty());
        const std::string filled = fill_template(text, v);
        EXPECT_EQ(filled.find("{{"), std::string::npos);
        ++n;
      }
  EXPECT_GT(n, 6);
}

// The error measures (validation/src/metrics.h) on histories whose errors are known.
TEST(Metrics, RelativeL2AndImpulseErrorsOfKnownHistories)
{
  using irdm::validation::ImpulseError;
  using irdm::validation::RelativeL2;
  // A history off by 10 % everywhere: 10 % in L2 and in impulse.
  RelativeL2   l2;
  ImpulseError impulse;
  for (const double f : {1.0, 3.0, 2.0, 0.5})
    {
      l2.add(1.1 * f, f);
      impulse.add(1.1 * f, f);
    }
  EXPECT_NEAR(l2.value(), 0.1, 1e-15);
  EXPECT_NEAR(impulse.value(), 0.1, 1e-15);
  // The same force a step late: the impulse is kept, the L2 error is not.
  RelativeL2   late;
  ImpulseError late_impulse;
  const std::vector<double> f = {0, 1, 0, 0}, g = {0, 0, 1, 0};
  for (size_t k = 0; k < f.size(); ++k)
    late.add(g[k], f[k]), late_impulse.add(g[k], f[k]);
  EXPECT_NEAR(late.value(), std::sqrt(2.0), 1e-15);
  EXPECT_EQ(late_impulse.value(), 0);
  // Vectors are their components; windows summed apart add up to the whole.
  RelativeL2 u, parts;
  u.add(std::vector<double>{1, 2}, std::vector<double>{1, 1});
  parts.add_squared(0, 1);
  parts.add_squared(1, 1);
  EXPECT_NEAR(u.value(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(u.value(), parts.value());
  // A run against itself, and against a zero truth (no division by zero).
  RelativeL2 same, zero;
  same.add(2.5, 2.5);
  zero.add(1e-160, 0);
  EXPECT_EQ(same.value(), 0);
  EXPECT_TRUE(std::isfinite(zero.value()));
}

// The nonlinear map's limits (validation/src/nonlinear_map.h): where a method's error passes a
// threshold as the load grows, on known lines.
TEST(NonlinearMap, PassingLoadIsInterpolatedInLogLoadBetweenTheNeighbours)
{
  using irdm::validation::nonlinear::passing_load;
  bool below = false, beyond = false;
  // 2 % at 1, 8 % at 4: 5 % is half way in log(load), at 2.
  EXPECT_NEAR(passing_load({{1, 0.02}, {4, 0.08}, {16, 0.3}}, 0.05, below, beyond), 2.0, 1e-12);
  EXPECT_FALSE(below || beyond);
  // 10 % between 4 (8 %) and 16 (30 %): a tenth of the way, 4 * 4^(1/11).
  EXPECT_NEAR(passing_load({{1, 0.02}, {4, 0.08}, {16, 0.3}}, 0.10, below, beyond),
              4 * std::pow(4.0, 1.0 / 11), 1e-12);
  // The first crossing counts, not a later return below it.
  EXPECT_NEAR(passing_load({{1, 0.02}, {4, 0.08}, {16, 0.01}}, 0.05, below, beyond), 2.0, 1e-12);
  EXPECT_TRUE(std::isnan(passing_load({{1, 0.2}, {4, 0.3}}, 0.05, below, beyond)));
  EXPECT_TRUE(below);
  EXPECT_TRUE(std::isnan(passing_load({{1, 0.01}, {4, 0.03}}, 0.05, below, beyond)));
  EXPECT_TRUE(beyond);
  // A run that did not measure (NaN: unstable or failed) is past at its load.
  EXPECT_EQ(passing_load({{1, 0.01}, {4, NAN}}, 0.05, below, beyond), 4.0);
}

TEST(NonlinearMap, LimitsUseATruthOnlyWhereItCoversTheWholeFamilyAndRowsRoundTrip)
{
  using namespace irdm::validation::nonlinear;
  std::vector<MapRow> rows;
  const auto add = [&](const std::string &c, const double load, const double e, const char *truth) {
    MapRow r;
    r.c = c, r.material = "2kPa", r.method = "m", r.family = "press_top", r.load = load;
    r.truth = truth, r.displacement_error = e, r.force_error = 2 * e, r.impulse_error = e / 2;
    rows.push_back(r);
  };
  add("a", 0.01, 0.02, p1_truth);
  add("b", 0.04, 0.08, p1_truth);
  add("a", 0.01, 0.03, p2_truth); // the P2 truth on one of the two cases only
  const auto p1 = limits(rows, p1_truth);
  ASSERT_EQ(p1.size(), 3u); // shape, force, impulse
  EXPECT_EQ(p1[0].measure, "shape");
  EXPECT_NEAR(p1[0].limit5, 0.02, 1e-12);
  EXPECT_TRUE(p1[0].beyond10);
  EXPECT_TRUE(p1[1].below5 == false && std::abs(p1[1].limit5 - 0.01 * std::pow(4.0, 1.0 / 12)) < 1e-12);
  EXPECT_TRUE(limits(rows, p2_truth).empty()) << "the P2 truth does not cover the family";
  add("b", 0.04, 0.06, p2_truth);
  EXPECT_EQ(limits(rows, p2_truth).size(), 3u);

  const std::string file = IRDM_TEST_TMP "/nonlinear_rows.csv";
  std::filesystem::create_directories(IRDM_TEST_TMP);
  {
    std::ofstream out(file);
    out << csv_header() << '\n';
    for (const MapRow &r : rows)
      out << csv_line(r) << '\n';
  }
  const std::vector<MapRow> back = read_rows(file);
  ASSERT_EQ(back.size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i)
    {
      EXPECT_EQ(csv_line(back[i]), csv_line(rows[i]));
      EXPECT_TRUE(std::isnan(back[i].deformation_error)) << "not measured stays not measured";
    }
  std::ofstream(file) << "case,material\nx,y\n";
  EXPECT_THROW(read_rows(file), irdm::InputError);
}

// Each case is mapped against its best truth: a finer mesh's over P2 on the same mesh (which
// refines the elements, not the faceted body) over P1; a family against a truth only where that
// truth covers it.
TEST(NonlinearMap, EachCaseIsMappedAgainstItsFinestTruth)
{
  using namespace irdm::validation::nonlinear;
  EXPECT_EQ(truth_rank(p1_truth), 0);
  EXPECT_EQ(truth_rank(p2_truth), 1);
  EXPECT_EQ(truth_rank("fem_neo_hookean_p1_cat_fine"), 2);
  EXPECT_EQ(truth_rank("fem_neo_hookean_p2_cat_fine"), 2);
  std::vector<MapRow> rows;
  const auto add = [&](const std::string &c, const double load, const std::string &truth) {
    MapRow r;
    r.c = c, r.material = "2kPa", r.method = "m", r.family = "press_side", r.load = load;
    r.truth = truth, r.displacement_error = r.force_error = r.impulse_error = 0.01;
    rows.push_back(r);
  };
  add("a", 0.01, p1_truth);
  add("b", 0.04, p1_truth);
  add("a", 0.01, "fem_neo_hookean_p1_cat_fine");
  add("a", 0.01, p2_truth);
  add("b", 0.04, p2_truth);
  const std::string dir = IRDM_TEST_TMP "/nonlinear_best";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  write_csvs(dir, rows);
  const std::vector<MapRow> best = read_rows(dir + "/nonlinear.csv");
  ASSERT_EQ(best.size(), 2u);
  EXPECT_EQ(best[0].c + " " + best[0].truth, "a fem_neo_hookean_p1_cat_fine");
  EXPECT_EQ(best[1].c + " " + best[1].truth, "b " + std::string(p2_truth));
  EXPECT_EQ(read_rows(dir + "/against_p1.csv").size(), 2u);
  // The limits: against P2 (it covers the family) and P1, not against the finer mesh (one case).
  std::ifstream limits(dir + "/limits.csv");
  const std::string text((std::istreambuf_iterator<char>(limits)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(std::string(",") + p2_truth + ","), std::string::npos);
  EXPECT_NE(text.find(std::string(",") + p1_truth + ","), std::string::npos);
  EXPECT_EQ(text.find("cat_fine"), std::string::npos);
}

// A run keeps the earlier rows of the families it does not run; with --keep-rows also those of
// its own families' cases and materials it did not make, and it replaces every earlier row
// (each method's, each truth's) of a case and material it made.
TEST(NonlinearMap, AKeepRowsRunReplacesOnlyTheCasesAndMaterialsItMade)
{
  using namespace irdm::validation::nonlinear;
  const auto row = [](const std::string &c, const std::string &material, const std::string &method,
                      const std::string &family) {
    MapRow r;
    r.c = c, r.material = material, r.method = method, r.family = family, r.truth = p1_truth;
    return r;
  };
  const std::vector<MapRow> earlier = {
    row("press_top_1mm", "2kPa", "vdof_nearest", "press_top"), row("drop_2cm", "2kPa", "route2_modal", "free_drop"),
    row("drop_2cm", "50kPa", "route2_modal", "free_drop"), row("drop_2cm", "50kPa", "route1_rigid_fit", "free_drop"),
    row("impact_0.2", "50kPa", "route2_modal", "free_impact")};
  const std::vector<MapRow> made = {row("drop_2cm", "50kPa", "route2_modal", "free_drop"),
                                    row("drop_2cm", "50kPa", "reduced_free_cat_50kPa", "free_drop")};
  const auto names = [](const std::vector<MapRow> &rows) {
    std::string s;
    for (const MapRow &r : rows)
      s += r.c + "/" + r.material + "/" + r.method + " ";
    return s;
  };
  EXPECT_EQ(names(rows_kept(earlier, made, {"free"}, false)), "press_top_1mm/2kPa/vdof_nearest ");
  EXPECT_EQ(names(rows_kept(earlier, made, {"free"}, true)),
            "press_top_1mm/2kPa/vdof_nearest drop_2cm/2kPa/route2_modal impact_0.2/50kPa/route2_modal ");
  EXPECT_EQ(names(rows_kept(earlier, made, {"planes", "free"}, true)),
            "press_top_1mm/2kPa/vdof_nearest drop_2cm/2kPa/route2_modal impact_0.2/50kPa/route2_modal ");
  EXPECT_EQ(names(rows_kept(earlier, {}, {"planes"}, false)),
            "drop_2cm/2kPa/route2_modal drop_2cm/50kPa/route2_modal drop_2cm/50kPa/route1_rigid_fit "
            "impact_0.2/50kPa/route2_modal ");
}
