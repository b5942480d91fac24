// The irdm program as a user meets it: options refused rather than truncated, a disk filling at
// every point of each writer's output (exit 4, nothing under the final name), crafted model
// files refused (exit 2), inputs never overwritten, commands that are not parallel refused
// under mpirun. Runs the real binary (IRDM_CLI).
#include <irdm/model.h>
#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/mesh.h>
#include <reference_fem/reduced_model.h>

#include "irdm_test_util.h"
#include "nonlinear_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include <sys/wait.h>

using namespace irdm_test;

namespace
{
  // Exit status of a shell command run with a clean environment (no MPI variables of ours).
  int
  status(const std::string &cmd)
  {
    const int s = std::system((clean_environment() + "bash -c '" + cmd + "' > /dev/null 2>&1").c_str());
    return WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  }

  std::string
  write_scene(const std::string &name, const std::string &extra, const double duration_s = 0.2)
  {
    std::string text = beam_scene(extra);
    const auto  at   = text.find("\"duration_s\": 0.2");
    text.replace(at, 17, "\"duration_s\": " + std::to_string(duration_s));
    const std::string path = tmp(name + ".json");
    std::ofstream(path) << text;
    return path;
  }
} // namespace

TEST(Cli, OptionsAreRefusedNotTruncated)
{
  const std::string cli = IRDM_CLI;
  const fem::Scene  scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "cli_opts.h5");
  const std::string model = tmp("cli_opts.h5");
  EXPECT_EQ(status(cli + " compress " + model + " --out " + tmp("o.h5") + " --max-delay 10.9"), 2);
  EXPECT_EQ(status(cli + " compress " + model + " --out " + tmp("o.h5") + " --blend 2.5"), 2);
  EXPECT_EQ(status(cli + " compress " + model + " --out " + model), 2); // input as output
  EXPECT_EQ(status(cli + " compress -h"), 0);
  EXPECT_EQ(status(cli + " precompute-vdof " + write_scene("cli_v", "") + " --out " +
                   tmp("v.h5") + " --subdivisions 0.5"),
            2);
  EXPECT_EQ(status(cli + " modes " + write_scene("cli_m", "") + " --count 1000000"), 2);
  EXPECT_EQ(status(cli + " precompute " + write_scene("cli_p", "") + " --out " +
                   tmp("no/such/folder/m.h5")),
            2);
  // validate-free: the truth's step divisions, one for every material or one per material,
  // refused before a report or a model is begun (the --out folder itself is made when the
  // options are checked, as for every validate command).
  const std::string free_scene = IRDM_MESH_DIR "/../validation/scenes/free/free_cat.json";
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --materials 1000,2000,3000 --fem-divisions 1,2"),
            2);
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --fem-divisions 0"),
            2);
  // The converged truth: P1 or P2, and cases of the study.
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-degree 3"),
            2);
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-degree 1"),
            2); // P1 on the scene's own mesh: the truth itself
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-mesh " + tmp("no_such.msh")),
            2);
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-mesh " IRDM_MESH_DIR "/beam_2.msh"),
            2); // another body's mesh
  // A mesh that checks the converged truth needs that truth, and must be of the same body.
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-check-mesh " IRDM_MESH_DIR "/cat.msh"),
            2);
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-mesh " IRDM_MESH_DIR
                   "/cat.msh --converged-check-mesh " IRDM_MESH_DIR "/beam_2.msh"),
            2);
  EXPECT_EQ(status(cli + " validate-free --scene " + free_scene + " --out " + tmp("vf") +
                   " --model-dir " + tmp("vfm") + " --converged-cases drop_3cm"),
            2);
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --converged-degree 1"), 2);
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --converged-mesh " IRDM_MESH_DIR
                   "/beam_2.msh"),
            2); // another body's mesh (the scene's is the cat)
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --converged-cases press_top_3mm"), 2);
  // --cases: a name that is neither a case nor a kind; a converged case the choice leaves out.
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --cases press_top_3mm"), 2);
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --cases slide_side"), 2);
  EXPECT_EQ(status(cli + " validate-planes --out " + tmp("vf") + " --reduced-model " + tmp("none.h5")), 2);
  // validate-nonlinear: its families, its lists and its converged cases, refused before any
  // model is made; nothing to redraw is refused rather than drawn empty.
  const std::string press_scene = IRDM_MESH_DIR "/../validation/scenes/press.json";
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --families bogus"), 2);
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --drops none drop_2cm"), 2);
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --families planes --scene " +
                   press_scene + " --converged-cases press_top_3mm --model " + tmp("vn_m.h5") +
                   " --vertex-model " + tmp("vn_v.h5")),
            2);
  // P1 on the scene's own mesh is the truth itself; a converged mesh must exist.
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --families planes --scene " +
                   press_scene + " --converged-degree 1 --model " + tmp("vn_m.h5") +
                   " --vertex-model " + tmp("vn_v.h5")),
            2);
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --families planes --scene " +
                   press_scene + " --converged-mesh " + tmp("no_such.msh") + " --model " +
                   tmp("vn_m.h5") + " --vertex-model " + tmp("vn_v.h5")),
            2);
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn") + " --scene " + press_scene +
                   " --free-scene " + free_scene + " --model " + tmp("vn_m.h5") + " --vertex-model " +
                   tmp("vn_v.h5") + " --materials 1000 2000 3000 --fem-divisions 1 2"),
            2);
  EXPECT_FALSE(fs::exists(tmp("vn_m.h5")));
  EXPECT_FALSE(fs::exists(tmp("vn_v.h5")));
  fs::remove_all(tmp("vn_empty"));
  EXPECT_EQ(status(cli + " validate-nonlinear --out " + tmp("vn_empty") + " --families none"), 2);
  EXPECT_FALSE(fs::exists(tmp("vn_empty") + "/nonlinear/nonlinear.md"));
  EXPECT_FALSE(fs::exists(tmp("vf") + "/free"));
  EXPECT_FALSE(fs::exists(tmp("vfm")));
  EXPECT_FALSE(fs::exists(tmp("o.h5")));
}

TEST(Cli, SimulateOnAFullDiskExitsFourAndLeavesNoResult)
{
  const std::string dir = tmp("full_disk_out");
  fs::remove_all(dir);
  // 4 s of surface displacement: about 9 MB of HDF5 and as much CSV.
  const std::string scene = write_scene(
    "cli_full", R"(, "outputs": {"directory": ")" + dir + R"(", "surface": true})", 4.0);
  // ulimit -f (1 KiB blocks): writes past 6 MiB fail with EFBIG, as on a full disk. (MPI's
  // start-up needs a few MiB of shared-memory files itself, so the limit cannot be smaller.)
  EXPECT_EQ(status("ulimit -f 6144; trap \"\" XFSZ; " + std::string(IRDM_CLI) + " simulate " +
                   scene + " --quiet"),
            4);
  EXPECT_FALSE(fs::exists(fs::path(dir) / "irdm_beam.h5"));
  EXPECT_FALSE(fs::exists(fs::path(dir) / "irdm_beam.h5.part"));
  // With room, the same run succeeds and writes it.
  EXPECT_EQ(status(std::string(IRDM_CLI) + " simulate " + scene + " --quiet"), 0);
  EXPECT_TRUE(fs::exists(fs::path(dir) / "irdm_beam.h5"));
}

TEST(Cli, ValidatePlanesNeverOverwritesAModelOfAnotherKind)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "cli_point.h5");
  const std::string model  = tmp("cli_point.h5");
  const std::string before = fem::file_hash(model);
  EXPECT_EQ(status(std::string(IRDM_CLI) + " validate-planes --scene " + write_scene("cli_vp", "") +
                   " --model " + model + " --out " + tmp("cli_vp_report") +
                   " --subdivisions 0 --length 10"),
            2);
  EXPECT_EQ(fem::file_hash(model), before);
}

// The converged truth on another mesh (--converged-mesh): given the scene's own mesh, no wall
// moves (the same outermost point) and every surface vertex takes its own displacement (its
// closest surface point is itself), so that truth is the P1 truth bit for bit: the P1 truth's row
// against it is zero, and every method's row against it is its row against the P1 truth.
TEST(Cli, AConvergedTruthOnTheScenesOwnMeshIsTheTruthItself)
{
  using namespace irdm::validation::nonlinear;
  const std::string out = tmp("cli_cm");
  fs::remove_all(out);
  ASSERT_EQ(status(std::string(IRDM_CLI) + " validate-nonlinear --families planes --scene " +
                   write_scene("cli_cm", "") + " --model " + tmp("cli_cm_v.h5") +
                   " --vertex-model " + tmp("cli_cm_x.h5") +
                   " --subdivisions 1 --length 20 --no-direct --press-directions top "
                   "--press-depths 0.001 --impact-speeds none --converged-cases press_top_1mm "
                   "--converged-mesh " IRDM_MESH_DIR "/beam_2.msh --out " + out),
            0);
  const std::vector<MapRow> best = read_rows(out + "/nonlinear/nonlinear.csv");
  const std::vector<MapRow> p1   = read_rows(out + "/nonlinear/against_p1.csv");
  ASSERT_EQ(best.size(), p1.size() + 1); // and the P1 truth's own row
  for (const MapRow &r : best)
    {
      EXPECT_EQ(r.truth, "fem_neo_hookean_p1_beam_2");
      if (r.method == p1_truth)
        {
          EXPECT_EQ(r.force_error, 0);
          EXPECT_EQ(r.displacement_error, 0);
          continue;
        }
      const auto same = std::find_if(p1.begin(), p1.end(), [&](const MapRow &q) { return q.method == r.method; });
      ASSERT_NE(same, p1.end()) << r.method;
      EXPECT_EQ(r.force_error, same->force_error) << r.method;
      EXPECT_EQ(r.impulse_error, same->impulse_error) << r.method;
      EXPECT_EQ(r.displacement_error, same->displacement_error) << r.method;
    }
  for (const char *f : {"cli_cm_v.h5", "cli_cm_x.h5"})
    fs::remove(tmp(f));
}

// The free family's converged truth on another mesh (validate-free --converged-mesh), given the
// scene's own mesh: no plane moves and every surface vertex takes its own displacement, so the
// truth is the P1 truth bit for bit: the P1 truth's row against it is zero, and each method's
// row against it is its first-contact row against the P1 truth. The same run checks the linear
// FEM at half its step (--truth-check): a run of its own, sampled at the same times. The
// converged truth's check on a coarser mesh (--converged-check-mesh), given the same mesh, is
// that truth.
TEST(Cli, AFreeConvergedTruthOnTheScenesOwnMeshIsTheTruthItself)
{
  const std::string out = tmp("cli_fcm");
  fs::remove_all(out);
  ASSERT_EQ(status(std::string(IRDM_CLI) + " validate-free --scene " IRDM_MESH_DIR
                   "/../validation/scenes/free/free_cat.json --materials 50000 --cases drop_2cm "
                   "--duration 0.1 --vdof-subdivisions -1 --force-modes 0 --stability 0.002 "
                   "--truth-check --no-corotational --converged-cases drop_2cm --converged-mesh " IRDM_MESH_DIR
                   "/cat.msh --converged-check-mesh " IRDM_MESH_DIR "/cat.msh --model-dir " +
                   tmp("cli_fcm_models") + " --out " + out),
            0);
  // Rows of a CSV by their first columns joined by ',' (case, material, method[, reference]).
  const auto rows = [](const std::string &file, const int key_columns) {
    std::ifstream                                          in(file);
    std::string                                            line;
    std::map<std::string, std::map<std::string, double>> by_key;
    std::vector<std::string>                               header;
    for (bool first = true; std::getline(in, line); first = false)
      {
        std::vector<std::string> cells;
        std::stringstream        ss(line);
        for (std::string cell; std::getline(ss, cell, ',');)
          cells.push_back(cell);
        if (first)
          {
            header = cells;
            continue;
          }
        std::string key;
        for (int k = 0; k < key_columns; ++k)
          key += (k ? "," : "") + cells[k];
        for (size_t k = key_columns; k < cells.size() && k < header.size(); ++k)
          by_key[key][header[k]] = std::stod(cells[k]);
      }
    return by_key;
  };
  const auto lin   = rows(out + "/free/linearization.csv", 4);
  const auto first = rows(out + "/free/first_contact.csv", 3);
  const std::string truth = "fem_neo_hookean_p1_cat";
  ASSERT_TRUE(lin.count("drop_2cm,50kPa," + truth + ",fem_neo_hookean"));
  const auto &self = lin.at("drop_2cm,50kPa," + truth + ",fem_neo_hookean");
  // The check mesh's truth against the converged one: the same mesh, so the same run, bit for
  // bit (a check run of another scene, step or degree would differ).
  const std::string check = "drop_2cm,50kPa," + truth + "," + truth;
  ASSERT_TRUE(lin.count(check));
  for (const char *e : {"first_force_error", "first_impulse_error", "first_deformation_error", "com_error", "force_error", "deformation_error"})
    {
      EXPECT_EQ(self.at(e), 0) << e;
      EXPECT_EQ(lin.at(check).at(e), 0) << e;
    }
  EXPECT_GT(lin.at(check).at("fem_ms_per_step"), 0);
  ASSERT_GE(first.size(), 2u);
  for (const auto &[key, row] : first)
    {
      const std::string against = key + "," + truth;
      ASSERT_TRUE(lin.count(against)) << against;
      EXPECT_EQ(lin.at(against).at("first_force_error"), row.at("force_error")) << key;
      EXPECT_EQ(lin.at(against).at("first_impulse_error"), row.at("impulse_error")) << key;
      EXPECT_EQ(lin.at(against).at("first_deformation_error"), row.at("deformation_error")) << key;
      EXPECT_GT(row.at("deformation_error"), 0) << key;
    }
  // The linear FEM at half its step against itself: another run (its contact differs), at the
  // same times (sampled at every second of its steps: its centre of mass within a hundredth of
  // the path; read at every step instead, each sample would be half the elapsed time early).
  const std::string half = "drop_2cm,50kPa,fem_linear_body_frame_half_step,fem_linear_body_frame";
  ASSERT_TRUE(lin.count(half));
  EXPECT_GT(lin.at(half).at("first_impulse_error"), 1e-9);
  EXPECT_LT(lin.at(half).at("first_impulse_error"), 0.1);
  EXPECT_GT(lin.at(half).at("com_error"), 0);
  EXPECT_LT(lin.at(half).at("com_error"), 0.01);
  // The linear FEM's path in series.csv beside the truth's, a row a step: before the first
  // contact both fall as Newmark integrates a constant force, alike to the printed digits;
  // after it they are two laws and part (so these rows are the linear FEM's, not the truth's).
  const double  contact = lin.at(half).at("start_s");
  std::ifstream in(out + "/free/series.csv");
  std::string   line;
  int           linear_rows = 0, falling = 0, parted = 0;
  while (std::getline(in, line))
    if (line.rfind("drop_2cm,50kPa,fem_linear_body_frame,", 0) == 0)
      {
        std::vector<double> v; // time_s .. deformation_difference_rms_m
        std::stringstream   ss(line.substr(line.find("frame,") + 6));
        for (std::string cell; std::getline(ss, cell, ',');)
          v.push_back(std::stod(cell));
        ASSERT_EQ(v.size(), 9u) << line;
        ++linear_rows;
        if (v[0] < contact - 1e-9)
          {
            ++falling;
            EXPECT_EQ(v[4], v[3]) << "centre of mass at " << v[0] << " s";
          }
        else if (v[8] > 1e-3 * v[7])
          ++parted;
      }
  EXPECT_EQ(linear_rows, 50); // 0.1 s at 2 ms
  // The converged truth's and its check's paths too (here both the truth itself: no difference).
  in.clear();
  in.seekg(0);
  int converged_rows = 0;
  while (std::getline(in, line))
    if (line.rfind("drop_2cm,50kPa," + truth + ",", 0) == 0)
      {
        ++converged_rows;
        EXPECT_EQ(line.substr(line.rfind(',') + 1), "0") << line;
      }
  EXPECT_EQ(converged_rows, 100);
  EXPECT_GT(falling, 10);
  EXPECT_GT(parted, 5);
}

TEST(Cli, CommandsThatAreNotParallelAreRefusedUnderMpirun)
{
  if (std::system("command -v mpirun > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "mpirun not installed";
  EXPECT_EQ(status("mpirun --allow-run-as-root --oversubscribe -np 2 " + std::string(IRDM_CLI) +
                   " modes " + write_scene("cli_mpi", "") + " --count 2"),
            2);
}

TEST(ResultWriter, StreamedOutputsEqualTheWholeResultsOutputs)
{
  // The same run written whole (write_outputs) and streamed in batches of 7 samples: the CSV
  // text and every HDF5 dataset must be identical, and the streamed run keeps only its last
  // batch in memory.
  const auto scene_with = [](const std::string &dir) {
    return fem::parse_scene(beam_scene(R"(, "outputs": {"directory": ")" + dir +
                                       R"(", "surface": true, "every": 3,
        "vertices": [{"name": "tip", "vertex": {"nearest_to_m": [0.25, 0.0, 0.01]}},
                     {"name": "mid", "vertex": {"nearest_to_m": [0.12, 0.0, 0.01]}}]},
        "loads": [{"type": "vertex_force", "name": "push", "vertex": {"nearest_to_m": [0.24, 0.0, 0.02]},
                   "force_N": [0, 0, -0.01]}])"),
                           ".");
  };
  const std::string whole_dir = tmp("stream_whole"), streamed_dir = tmp("stream_batches");
  fs::remove_all(whole_dir);
  fs::remove_all(streamed_dir);
  {
    const fem::Scene     s = scene_with(whole_dir);
    fem::ElasticDynamics f(s);
    f.write_outputs(f.run());
  }
  {
    const fem::Scene       s = scene_with(streamed_dir);
    fem::ElasticDynamics   f(s);
    fem::ResultWriter      w(s, f.n_dofs(), fem::n_samples(s));
    const fem::RunResult   r = f.run({}, [&](const fem::RunResult &b) { w.append(b); }, 7);
    EXPECT_LE(r.time.size(), 7u);
    w.finish(r);
  }
  const auto text = [](const std::string &p) {
    std::ifstream      in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  };
  for (const char *csv : {"/irdm_beam_series.csv", "/irdm_beam_surface.csv"})
    {
      const std::string a = text(whole_dir + csv), b = text(streamed_dir + csv);
      EXPECT_GT(a.size(), 1000u) << csv;
      EXPECT_EQ(a, b) << csv;
    }
  EXPECT_NE(text(whole_dir + "/irdm_beam_series.csv").find("tip_ux_m,tip_uy_m,tip_uz_m,mid_ux_m"),
            std::string::npos)
    << "columns follow the scene's order";
  h5::Reader a(whole_dir + "/irdm_beam.h5"), b(streamed_dir + "/irdm_beam.h5");
  for (const char *set : {"/time", "/energy/kinetic", "/energy/strain",
                          "/vertices/tip/displacement", "/vertices/mid/displacement",
                          "/fixed/clamp/reaction", "/surface/displacement"})
    {
      SCOPED_TRACE(set);
      const auto shape = a.shape(set);
      EXPECT_EQ(b.shape(set), shape);
      EXPECT_EQ(a.read_double(set, shape), b.read_double(set, shape));
    }
  EXPECT_EQ(a.double_attribute("/vertices/tip", "node_tag"),
            b.double_attribute("/vertices/tip", "node_tag"));
}

TEST(Cli, ASecondPrecomputeToTheSameOutIsRefusedAndTheFirstFinishes)
{
  // The first run is stood in for by this test: it holds the output's lock (OutputLock, as a
  // running precompute does) over a part file of its work, so no timing decides the outcome.
  const std::string scene = write_scene("cli_concurrent", ""), out = tmp("cli_concurrent.h5");
  for (const auto &f : {out, out + ".part", out + ".lock"})
    fs::remove(f);
  const std::string run = std::string(IRDM_CLI) + " precompute " + scene + " --out " + out +
                          " --quiet";
  const std::string work = "the first run's partial work";
  {
    const OutputLock first(out);
    std::ofstream(out + ".part") << work;
    EXPECT_EQ(status(run), 2) << "the second run must be refused";
    std::ifstream     part(out + ".part");
    const std::string kept((std::istreambuf_iterator<char>(part)), std::istreambuf_iterator<char>());
    EXPECT_EQ(kept, work) << "the first run's part file was touched";
    EXPECT_FALSE(fs::exists(out));
  }
  // Once the first run has let go, a run finishes (discarding a part file it cannot read).
  EXPECT_EQ(status(run), 0);
  EXPECT_NO_THROW(load_model(out));
  EXPECT_FALSE(fs::exists(out + ".lock"));
  EXPECT_FALSE(fs::exists(out + ".part"));
}

namespace
{
  std::pair<int, std::string>
  status_and_error(const std::string &cmd);
}

TEST(Cli, ValidateNeverTouchesAModelAlreadyInItsModelsFolder)
{
  const std::string scenes = tmp("cli_validate_scenes"), models = tmp("cli_validate_models");
  fs::remove_all(scenes);
  fs::remove_all(models);
  fs::create_directories(scenes);
  fs::create_directories(models);
  // A probe, so that the scene has something to validate and only the model stops it.
  const std::string probe = R"(, "probes": [{"name": "finger", "surface": "sides",
      "direction": [0, 0, -1], "unilateral": false, "until_s": 0.15,
      "path": {"times_s": [0, 0.2], "points_m": [[0.21, 0.001, 0.01], [0.235, -0.002, 0.01]]},
      "depth": {"times_s": [0, 0.05, 0.1, 0.12], "values_m": [0, 0.002, 0.002, 0.001]}}])";
  std::ofstream(fs::path(scenes) / "irdm_beam.json") << beam_scene(probe);
  const std::string mine = (fs::path(models) / "irdm_beam.h5").string();
  std::ofstream(mine) << "a user's file";
  const auto [user_code, user_error] =
    status_and_error(std::string(IRDM_CLI) + " validate --scenes " + scenes + " --models " +
                     models + " --out " + tmp("cli_validate_report") + " --no-full-model");
  EXPECT_EQ(user_code, 2);
  EXPECT_NE(user_error.find("'" + mine + "' exists"), std::string::npos) << user_error;
  std::ifstream in(mine);
  std::string   content;
  std::getline(in, content);
  EXPECT_EQ(content, "a user's file");
  // A model a stopped validate left there: refused too, with the command that clears it.
  fs::remove(mine);
  make_model(fem::parse_scene(beam_scene(""), "."), "cli_validate_leftover.h5");
  fs::copy_file(tmp("cli_validate_leftover.h5"), mine);
  const auto [code, error] =
    status_and_error(std::string(IRDM_CLI) + " validate --scenes " + scenes + " --models " +
                     models + " --out " + tmp("cli_validate_report") + " --no-full-model");
  EXPECT_EQ(code, 2);
  EXPECT_NE(error.find("rm '" + mine + "'"), std::string::npos) << error;
  EXPECT_TRUE(fs::exists(mine));
}

TEST(Cli, ARunLargerThanTheDiskIsRefusedBeforeItStarts)
{
  // 9.5e7 steps (just under the scene's 1e8 limit) with the surface kept: about 440 GB of
  // results. Refused before the first step (exit 2, the disk named), not after filling it.
  const std::string dir = tmp("huge_out");
  fs::remove_all(dir);
  fs::create_directories(dir);
  if (irdm::available_disk_bytes(dir) > 4e11)
    GTEST_SKIP() << "more than 400 GB free: this run would fit";
  const std::string scene = write_scene(
    "cli_huge", R"(, "outputs": {"directory": ")" + dir + R"(", "surface": true, "csv": false})",
    1.9e5);
  const std::string err = tmp("cli_huge.err");
  EXPECT_EQ(std::system((clean_environment() + std::string(IRDM_CLI) + " simulate " + scene +
                         " --quiet 2> " + err)
                          .c_str()) >> 8,
            2);
  std::stringstream message;
  message << std::ifstream(err).rdbuf();
  EXPECT_NE(message.str().find("of disk"), std::string::npos) << message.str();
  EXPECT_TRUE(fs::is_empty(dir));
}

// Linear kinematics with planes (vertex contact): simulate runs, prints its summary and writes
// the planes' force and penetration; the scene rules of the two plane contacts are enforced.
TEST(Cli, SimulateRunsLinearPlanesByVertexContact)
{
  const std::string dir = tmp("linear_planes_out");
  fs::remove_all(dir);
  const std::string wall = R"(, "planes": [{"name": "wall", "normal": [-1, 0, 0], "vertex_stiffness_N_m": 20,
      "position": {"times_s": [0, 0.05], "points_m": [[0.2502, 0, 0], [0.249, 0, 0]]}}])";
  const std::string scene =
    write_scene("cli_linear_planes", wall + R"(, "outputs": {"directory": ")" + dir + R"("})", 0.1);
  EXPECT_EQ(status(std::string(IRDM_CLI) + " simulate " + scene + " --quiet"), 0);
  std::ifstream csv(fs::path(dir) / "irdm_beam_series.csv");
  std::string   header;
  std::getline(csv, header);
  EXPECT_NE(header.find("wall_Fx_N"), std::string::npos) << header;
  EXPECT_NE(header.find("wall_penetration_m"), std::string::npos) << header;
  // penalty_Pa_m belongs to nonlinear kinematics, vertex_stiffness_N_m to linear, and linear
  // scenes take probes or planes, not both.
  EXPECT_THROW(fem::parse_scene(beam_scene(R"(, "planes": [{"name": "w", "normal": [-1, 0, 0], "penalty_Pa_m": 1e5,
      "position": {"times_s": [0], "points_m": [[0.26, 0, 0]]}}])"), "."), InputError);
  EXPECT_THROW(fem::parse_scene(beam_scene(R"(, "kinematics": "nonlinear", "planes": [{"name": "w", "normal": [-1, 0, 0],
      "vertex_stiffness_N_m": 20, "position": {"times_s": [0], "points_m": [[0.26, 0, 0]]}}])"), "."), InputError);
  EXPECT_THROW(fem::parse_scene(beam_scene(wall + R"(, "probes": [{"name": "p", "surface": "sides",
      "direction": [0, 0, -1], "path": {"times_s": [0], "points_m": [[0.2, 0.005, 0.01]]},
      "depth": {"times_s": [0], "values_m": [0]}}])"), "."), InputError);
  EXPECT_NO_THROW(fem::parse_scene(beam_scene(wall), "."));
  // A turning plane (normal_path) is nonlinear only; its normals may not vanish or flip.
  const auto turning = [&](const std::string &kinematics, const std::string &normals) {
    return fem::parse_scene(beam_scene(kinematics + R"(, "planes": [{"name": "w", "normal": [-1, 0, 0],
      "normal_path": {"times_s": [0, 1], "normals": )" + normals + R"(},
      "position": {"times_s": [0], "points_m": [[0.26, 0, 0]]}}])"), ".");
  };
  EXPECT_THROW(turning("", "[[-1, 0, 0], [-1, 0.1, 0]]"), InputError);
  EXPECT_THROW(turning(R"(, "kinematics": "nonlinear")", "[[-1, 0, 0], [0, 0, 0]]"), InputError);
  EXPECT_THROW(turning(R"(, "kinematics": "nonlinear")", "[[-1, 0, 0], [1, 0.1, 0]]"), InputError);
  const auto ok = turning(R"(, "kinematics": "nonlinear")", "[[-2, 0, 0], [-1, 1, 0]]");
  const auto n  = ok.planes[0].normal_at(0.5); // halfway: (-1.5, 0.5, 0) made unit
  EXPECT_NEAR(n[0], -1.5 / std::sqrt(2.5), 1e-15);
  EXPECT_NEAR(n[1], 0.5 / std::sqrt(2.5), 1e-15);
}

namespace
{
  // irdm play's summary.csv: its one row by column name (empty if it cannot be read).
  std::map<std::string, double>
  play_summary(const std::string &dir)
  {
    std::ifstream                 csv(fs::path(dir) / "summary.csv");
    std::string                   header, row;
    std::map<std::string, double> v;
    if (!std::getline(csv, header) || !std::getline(csv, row))
      return v;
    std::stringstream h(header), r(row);
    for (std::string name, value; std::getline(h, name, ',') && std::getline(r, value, ',');)
      v[name] = std::stod(value);
    return v;
  }
} // namespace

// irdm play on the beam: both loops run, the files other programs read are there with their
// columns, and with every mode in the force loop the real-time forces are the offline replay's
// (force_error 0: the threads change nothing). A bad trajectory is refused (exit 2).
TEST(Cli, PlayRunsBothLoopsAndMatchesTheOfflineReplay)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "cli_play.h5");
  const std::string trajectory = tmp("cli_play_device.csv");
  // Into the free end (x = 0.25 m, outward normal +x) by 5 mm and back, over 0.2 s.
  std::ofstream(trajectory) << "time_s,x_m,y_m,z_m\n0,0.255,0,0.01\n0.1,0.245,0,0.01\n0.2,0.255,0,0.01\n";
  const std::string dir = tmp("cli_play_out");
  fs::remove_all(dir);
  const std::string play = std::string(IRDM_CLI) + " play " + tmp("cli_play.h5") +
                           " --rate-hz 2000 --display-hz 200 --frames 3 --quiet --out " + dir;
  const int s = status(play + " --trajectory " + trajectory);
  EXPECT_TRUE(s == 0 || s == 3) << s; // 3: more than 0.1 % of deadlines missed (a busy machine)
  std::map<std::string, double> v = play_summary(dir);
  ASSERT_FALSE(v.empty()) << "no summary.csv";
  std::string header;
  EXPECT_EQ(v["steps"], 100);
  EXPECT_NE(v["baseline_missed"], -1); // the baseline ran
  EXPECT_NE(v["force_error"], -1);     // the offline replay ran, and the loop matches it
  EXPECT_LT(v["force_error"], 1e-12);
  // forces.csv, one row per step: no force while the device is outside the beam (x > 0.25 m),
  // a force at the deepest point, the largest the summary's peak.
  {
    std::ifstream forces(fs::path(dir) / "forces.csv");
    ASSERT_TRUE(std::getline(forces, header));
    EXPECT_EQ(header.rfind("step,time_s,device_x_m,device_y_m,device_z_m,present,force_x_N,"
                           "force_y_N,force_z_N", 0),
              0u);
    long   rows = 0;
    double peak = 0;
    for (std::string line; std::getline(forces, line); ++rows)
      {
        std::stringstream   l(line);
        std::vector<double> x;
        for (std::string cell; std::getline(l, cell, ',');)
          x.push_back(std::stod(cell));
        ASSERT_GE(x.size(), 9u);
        const double f = std::hypot(x[6], x[7], x[8]);
        peak           = std::max(peak, f);
        if (x[2] > 0.2501)
          {
            EXPECT_EQ(f, 0) << "a force with the device outside, step " << x[0];
          }
        if (x[0] == 49) // the deepest point, 5 mm in
          {
            EXPECT_GT(f, 0) << "no force at the deepest point";
          }
      }
    EXPECT_EQ(rows, 100);
    EXPECT_GT(peak, 1e-4); // the probe pressed the beam
    EXPECT_NEAR(peak, v["peak_force_N"], 1e-9 * peak);
  }
  EXPECT_GT(v["surface_updates"], 0);
  EXPECT_EQ(v["keep_warm"], 1); // both warm-ups repeat up to the tick unless --warm-once
  EXPECT_EQ(v["warm_step"], 1);
  EXPECT_TRUE(fs::exists(fs::path(dir) / "forces.csv"));
  EXPECT_TRUE(fs::exists(fs::path(dir) / "surface" / "surface.pvd"));
  // One row per surface update, each with the force step it showed: in order, none past the last.
  std::ifstream updates(fs::path(dir) / "surface_updates.csv");
  ASSERT_TRUE(std::getline(updates, header));
  EXPECT_EQ(header, "update,steps,surface_update_us");
  long   n_rows     = 0;
  double last_steps = 0;
  for (std::string line; std::getline(updates, line); ++n_rows)
    {
      std::stringstream l(line);
      std::string       index, steps, us;
      ASSERT_TRUE(std::getline(l, index, ',') && std::getline(l, steps, ',') && std::getline(l, us));
      EXPECT_EQ(std::stod(index), n_rows);
      EXPECT_GT(std::stod(steps), last_steps);
      EXPECT_LE(std::stod(steps), 100);
      EXPECT_GT(std::stod(us), 0);
      last_steps = std::stod(steps);
    }
  EXPECT_EQ(n_rows, v["surface_updates"]);
  std::ofstream(tmp("cli_play_bad.csv")) << "time_s,x_m,y_m\n0,0.255,0\n";
  EXPECT_EQ(status(play + "_bad --trajectory " + tmp("cli_play_bad.csv")), 2);
  EXPECT_EQ(status(play + "_missing --trajectory " + tmp("no_such.csv")), 2);
}

// irdm play --force-tolerance: the force loop's modes chosen before the run, the fewest of the
// grid whose offline forces over the trajectory are within the tolerance of every mode's; the
// real-time run then meets it against the exact replay (the loop is deterministic).
TEST(Cli, PlayChoosesTheFewestForceLoopModesWithinATolerance)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto       model = make_model(scene, "cli_play_tol.h5");
  const std::string trajectory = tmp("cli_play_tol_device.csv");
  std::ofstream(trajectory) << "time_s,x_m,y_m,z_m\n0,0.255,0,0.01\n0.1,0.245,0,0.01\n0.2,0.255,0,0.01\n";
  const auto run = [&](const double tolerance, const std::string &dir) {
    fs::remove_all(dir);
    const int s = status(std::string(IRDM_CLI) + " play " + tmp("cli_play_tol.h5") +
                         " --rate-hz 2000 --display-hz 200 --frames 2 --surface-modes 5 --quiet"
                         " --no-baseline --force-tolerance " + std::to_string(tolerance) +
                         " --trajectory " + trajectory + " --out " + dir);
    EXPECT_TRUE(s == 0 || s == 3) << s;
    return play_summary(dir);
  };
  // A rigid probe at the free end: the modes left quasi-static cost much in force.
  auto loose = run(0.5, tmp("loose")), tight = run(0.2, tmp("tight"));
  ASSERT_FALSE(loose.empty());
  ASSERT_FALSE(tight.empty());
  EXPECT_GE(loose["force_modes"], 25);
  EXPECT_LT(loose["force_modes"], model.modes.n_modes);
  EXPECT_LE(loose["force_error"], 0.5);
  EXPECT_GT(tight["force_modes"], loose["force_modes"]);
  EXPECT_LE(tight["force_error"], 0.2);
  EXPECT_LT(tight["force_modes"], model.modes.n_modes);
  EXPECT_EQ(status(std::string(IRDM_CLI) + " play " + tmp("cli_play_tol.h5") + " --trajectory " +
                   trajectory + " --force-tolerance 0.05 --force-modes 30 --out " + tmp("both")),
            2); // one or the other
  EXPECT_EQ(status(std::string(IRDM_CLI) + " play " + tmp("cli_play_tol.h5") + " --trajectory " +
                   trajectory + " --lag-steps 1 --out " + tmp("lagged")),
            2); // a reduced model's option
}

// irdm play with a reduced nonlinear model: the seed's split runs (the force loop on the local
// compliance, the deformation loop taking the Newton step), writes the files other programs
// read with their columns, and offline the split follows the coupling solved inside the step.
// Without a coupling the command refuses (exit 2).
TEST(Cli, PlayRunsTheReducedModelsTwoLoops)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(R"(, "kinematics": "nonlinear")"), ".");
  fem::ReducedModelOptions ro;
  ro.output           = tmp("cli_play_reduced.h5");
  ro.modes            = 6;
  ro.derivative_modes = 3;
  ro.residual_modes   = false;
  ro.basis_size       = 12;
  fs::remove(ro.output);
  fem::precompute_reduced_model(scene, ro);
  const std::string trajectory = tmp("cli_play_reduced_device.csv");
  // Into the free end (x = 0.25 m, outward normal +x) by 5 mm and back, over 0.2 s.
  std::ofstream(trajectory) << "time_s,x_m,y_m,z_m\n0,0.255,0,0.01\n0.1,0.245,0,0.01\n0.2,0.255,0,0.01\n";
  const std::string dir = tmp("cli_play_reduced_out");
  fs::remove_all(dir);
  const std::string play = std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                           " --rate-hz 1000 --quiet --out " + dir;
  EXPECT_EQ(status(play + "_refused"), 2) << "a reduced model needs a coupling";
  const int s = status(play + " --coupling-stiffness 100 --coupling-damping 0.2");
  EXPECT_TRUE(s == 0 || s == 3) << s; // 3: more than 0.1 % of deadlines missed (a busy machine)
  std::map<std::string, double> v = play_summary(dir);
  ASSERT_FALSE(v.empty()) << "no summary.csv";
  std::string header;
  EXPECT_EQ(v["steps"], 200);
  EXPECT_EQ(v["deformation_steps"], 100);
  EXPECT_GT(v["peak_force_N"], 1e-3) << "the coupling pressed the beam";
  EXPECT_GT(v["force_step_p99_us"], 0);
  EXPECT_GT(v["deformation_step_p50_us"], 0);
  EXPECT_GE(v["split_force_error"], 0) << "the offline checks ran";
  EXPECT_LT(v["split_force_error"], 0.05);
  EXPECT_EQ(v["failed_steps"], 0);
  std::ifstream deformation(fs::path(dir) / "deformation.csv");
  ASSERT_TRUE(std::getline(deformation, header));
  EXPECT_EQ(header, "step,time_s,deformation_step_us,lag_ms,newton_iterations,force_x_N,force_y_N,"
                    "force_z_N,probed_u_x_m,probed_u_y_m,probed_u_z_m,tangents_made,staged_tangents_taken");
  long   rows = 0;
  double made = 0; // tangents made in the steps
  for (std::string line; std::getline(deformation, line); ++rows)
    {
      std::stringstream fields(line);
      std::string       field;
      for (int c = 0; c < 12 && std::getline(fields, field, ','); ++c)
        ;
      made += std::stod(field); // column 12, tangents_made
    }
  EXPECT_EQ(rows, 100);
  EXPECT_EQ(v["tangent_evaluations"], made + 1) << "the steps' and the one before the loops";
  EXPECT_EQ(v["tangent_steps"], 8) << "the default";
  ASSERT_TRUE(v.count("late_steps")) << "the steps published more than a model step late";
  ASSERT_TRUE(v.count("late_steps_in_a_row"));
  // The tangent made in the step and over 3 steps: the split as close to its reference.
  const std::string staged = dir + "_staged";
  fs::remove_all(staged);
  const int s3 = status(std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                        " --rate-hz 1000 --quiet --coupling-stiffness 100 --coupling-damping 0.2 --tangent-steps 3 --out " +
                        staged);
  EXPECT_TRUE(s3 == 0 || s3 == 3) << s3;
  std::map<std::string, double> w = play_summary(staged);
  ASSERT_FALSE(w.empty()) << "no summary.csv";
  EXPECT_EQ(w["tangent_steps"], 3);
  EXPECT_EQ(w["failed_steps"], 0);
  EXPECT_LT(w["split_force_error"], 0.05);
  fs::remove_all(staged);
  // In the step, and the split's offline check again with its force loop 1 and 2 steps behind
  // (lag.csv: lag 0 first, the lockstep split itself).
  const int s0 = status(std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                        " --rate-hz 1000 --quiet --coupling-stiffness 100 --coupling-damping 0.2 --tangent-steps 0 "
                        "--lag-steps 1 2 --out " + staged);
  EXPECT_TRUE(s0 == 0 || s0 == 3) << s0;
  w = play_summary(staged);
  EXPECT_EQ(w["tangent_steps"], 0);
  EXPECT_EQ(w["staged_tangent_evaluations"], 0);
  EXPECT_LT(w["split_force_error"], 0.05);
  std::ifstream lag(fs::path(staged) / "lag.csv");
  ASSERT_TRUE(std::getline(lag, header)) << "no lag.csv";
  EXPECT_EQ(header, "lag_steps,lag_ms,force_error,lockstep_difference,peak_force_N,failed_steps,cut_steps,"
                    "most_newton_iterations");
  std::vector<std::vector<double>> lags;
  for (std::string line; std::getline(lag, line);)
    {
      std::stringstream        fields(line);
      std::vector<double>      row;
      for (std::string field; std::getline(fields, field, ',');)
        row.push_back(std::stod(field));
      lags.push_back(row);
    }
  ASSERT_EQ(lags.size(), 3u);
  EXPECT_EQ(lags[0][0], 0);
  EXPECT_EQ(lags[2][0], 2);
  EXPECT_DOUBLE_EQ(lags[2][1], 4) << "2 steps of 2 ms";
  EXPECT_NEAR(lags[0][2], w["split_force_error"], 1e-12 + 1e-6 * w["split_force_error"]) << "lag 0: the lockstep split";
  EXPECT_EQ(lags[0][3], 0);
  EXPECT_GT(lags[1][3], 0) << "a lag changes the forces";
  EXPECT_GT(lags[2][3], lags[1][3]) << "two steps more than one";
  // Again without --lag-steps: the earlier run's lag.csv is gone; with --no-check refused.
  const int again = status(std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                           " --rate-hz 1000 --quiet --coupling-stiffness 100 --coupling-damping 0.2 --out " + staged);
  EXPECT_TRUE(again == 0 || again == 3) << again;
  EXPECT_FALSE(fs::exists(fs::path(staged) / "lag.csv"));
  EXPECT_EQ(status(std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                   " --coupling-stiffness 100 --lag-steps 2 --no-check --out " + staged),
            2);
  EXPECT_NE(status(std::string(IRDM_CLI) + " play " + ro.output + " --trajectory " + trajectory +
                   " --coupling-stiffness 100 --tangent-steps -1 --out " + staged),
            0);
  std::ifstream forces(fs::path(dir) / "forces.csv");
  ASSERT_TRUE(std::getline(forces, header));
  EXPECT_EQ(header.rfind("step,time_s,device_x_m,device_y_m,device_z_m,present,force_x_N,", 0), 0u);
}

namespace
{
  // Stores a string attribute of the root as an array of two fixed-length strings (what a
  // hostile or foreign writer may leave), in place.
  void
  store_as_string_array(const std::string &path, const std::string &name)
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    H5Adelete(f, name.c_str());
    const hsize_t two   = 2;
    const hid_t   space = H5Screate_simple(1, &two, nullptr), type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 64);
    const hid_t attr = H5Acreate2(f, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
    const std::string text(2 * 64, 'x');
    H5Awrite(attr, type, text.data());
    H5Aclose(attr);
    H5Tclose(type);
    H5Sclose(space);
    H5Fclose(f);
  }

  // Exit status and standard error of a command.
  std::pair<int, std::string>
  status_and_error(const std::string &cmd)
  {
    const std::string err = tmp("stderr.txt");
    const int s = std::system((clean_environment() + "bash -c '" + cmd + "' > /dev/null 2> " +
                               err).c_str());
    std::ifstream      in(err);
    std::ostringstream text;
    text << in.rdbuf();
    return {WIFEXITED(s) ? WEXITSTATUS(s) : 128 + WTERMSIG(s), text.str()};
  }
} // namespace

// The class of crafted file that corrupted the heap: a string attribute stored as an array of
// fixed-length strings, in a full and in a compressed model, read by every command that loads
// one. Each refuses with exit 2, naming the file and the attribute; none ends in a signal.
TEST(Cli, AStringAttributeStoredAsAnArrayIsRefusedByEveryCommand)
{
  const std::string cli = IRDM_CLI;
  const fem::Scene  scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "crafted_source.h5");
  const std::string source = tmp("crafted_source.h5"), compressed = tmp("crafted_source_c.h5");
  ASSERT_EQ(status(cli + " compress " + source + " --out " + compressed + " --quiet"), 0);
  const std::string trajectory = tmp("crafted_device.csv");
  std::ofstream(trajectory) << "time_s,x_m,y_m,z_m\n0,0.255,0,0.01\n0.1,0.245,0,0.01\n";
  for (const std::string &original : {source, compressed})
    for (const std::string name : {"format", "integrator", "mesh_hash"})
      {
        const std::string crafted = tmp("crafted_" + name + ".h5");
        fs::copy_file(original, crafted, fs::copy_options::overwrite_existing);
        store_as_string_array(crafted, name);
        for (const std::string &command :
             {" compare-models " + source + " " + crafted, " compare-models " + crafted + " " + source,
              " compress " + crafted + " --out " + tmp("crafted_out.h5") + " --quiet",
              " play " + crafted + " --trajectory " + trajectory + " --quiet --out " +
                tmp("crafted_play")})
          {
            SCOPED_TRACE(fs::path(original).filename().string() + " @" + name + ":" + command);
            const auto [code, error] = status_and_error(cli + command);
            EXPECT_EQ(code, 2) << error;
            EXPECT_NE(error.find(crafted), std::string::npos) << error;
            // The attribute is named, unless the file was refused by its format first (a
            // compressed model where a full one is needed).
            if (error.find("'format' is missing or different") == std::string::npos)
              {
                EXPECT_NE(error.find(name), std::string::npos) << error;
              }
            EXPECT_FALSE(fs::exists(tmp("crafted_out.h5")));
          }
      }
}

namespace
{
  // Runs `command`, which writes `out`, under file-size limits at 10 points spread over the
  // output's length (ulimit -f, SIGXFSZ ignored: a write past it fails as on a full disk; MPI
  // start-up kept off files by PMIX_MCA_gds=hash). Each run ends written whole (exit 0), or
  // with exit 4, nothing under the final name and no lock; its part file is gone too, unless
  // `keeps_part` (the precompute keeps it to resume, and the next run with room then finishes).
  void
  expect_cli_fails_cleanly_at_every_size(const std::string &command, const std::string &out,
                                         const bool keeps_part)
  {
    const auto clear = [&] {
      for (const auto &f : {out, out + ".part", out + ".lock"})
        fs::remove(f);
    };
    clear();
    ASSERT_EQ(status(command), 0);
    const auto size   = fs::file_size(out);
    int        failed = 0;
    for (int i = 0; i < 10; ++i)
      {
        const auto kib = size * i / 10 / 1024;
        SCOPED_TRACE(command + " under " + std::to_string(kib) + " KiB of " +
                     std::to_string(size / 1024));
        clear();
        const int code = status("ulimit -f " + std::to_string(kib) +
                                "; trap \"\" XFSZ; PMIX_MCA_gds=hash " + command);
        EXPECT_TRUE(code == 0 || code == 4) << "exit status " << code;
        if (code == 0)
          continue;
        ++failed;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_FALSE(fs::exists(out + ".lock"));
        if (!keeps_part)
          {
            EXPECT_FALSE(fs::exists(out + ".part"));
          }
        else if (fs::exists(out + ".part"))
          {
            EXPECT_EQ(status(command), 0) << "the kept part file did not resume";
          }
      }
    EXPECT_GT(failed, 5);
  }
} // namespace

// Each writer of the FEM side, and compress, with the disk filling at every point of its output.
TEST(Cli, EveryWriterOnAFillingDiskExitsFourAndLeavesNothingBehind)
{
  const std::string cli = IRDM_CLI;
  std::string       text = beam_scene("");
  text.replace(text.find("\"length\": 100"), 13, "\"length\": 12");
  const std::string scene = tmp("filling.json");
  std::ofstream(scene) << text;
  const std::string model = tmp("filling_model.h5");
  expect_cli_fails_cleanly_at_every_size(cli + " precompute " + scene + " --out " + model +
                                           " --chunk 4 --quiet",
                                         model, true);
  expect_cli_fails_cleanly_at_every_size(
    cli + " compress " + model + " --out " + tmp("filling_c.h5") + " --theta 0.999 --quiet",
    tmp("filling_c.h5"), false);
  expect_cli_fails_cleanly_at_every_size(cli + " precompute-vdof " + scene + " --out " +
                                           tmp("filling_v.h5") + " --subdivisions 0 --quiet",
                                         tmp("filling_v.h5"), false);
  const std::string dir = tmp("filling_out");
  fs::create_directories(dir);
  const std::string sim = write_scene(
    "filling_sim", R"(, "outputs": {"directory": ")" + dir + R"(", "surface": true})", 0.1);
  expect_cli_fails_cleanly_at_every_size(cli + " simulate " + sim + " --quiet",
                                         dir + "/irdm_beam.h5", false);
}

// ERA from noisy responses (compress --noise, a measured-response stand-in): the same seed
// draws the same model, another seed another; the file says what it was identified from; noise
// is refused where it means nothing (balanced truncation reads the modes) or would bias the
// sizing (with --tolerance).
TEST(Cli, NoisyIdentificationIsReproducibleBySeed)
{
  const std::string cli   = IRDM_CLI;
  const fem::Scene  scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "noise_src.h5");
  const std::string src = tmp("noise_src.h5");
  const auto era = [&](const std::string &out, const std::string &extra) {
    return status(cli + " compress " + src + " --method era --order 60 --quiet --out " + tmp(out) + " " + extra);
  };
  ASSERT_EQ(era("a.h5", "--noise 1e-3 --seed 3"), 0);
  ASSERT_EQ(era("b.h5", "--noise 1e-3 --seed 3"), 0);
  ASSERT_EQ(era("c.h5", "--noise 1e-3 --seed 4"), 0);
  ASSERT_EQ(era("clean.h5", ""), 0);
  const auto a = load_state_space_model(tmp("a.h5")), b = load_state_space_model(tmp("b.h5")),
             c = load_state_space_model(tmp("c.h5")), clean = load_state_space_model(tmp("clean.h5"));
  EXPECT_EQ(a.d, b.d);
  EXPECT_EQ(a.c, b.c);
  EXPECT_NE(a.d, c.d);
  EXPECT_NE(a.d, clean.d);
  EXPECT_NE(a.identified_from.find("seed 3"), std::string::npos) << a.identified_from;
  EXPECT_EQ(clean.identified_from, "H as stored");
  EXPECT_EQ(status(cli + " compress " + src + " --method balanced --order 30 --noise 1e-3 --out " + tmp("x.h5")), 2);
  EXPECT_EQ(era("y.h5", "--noise 1e-3 --tolerance 0.01 --scene " + write_scene("noise_scene", beam_probe)), 2);
  EXPECT_FALSE(std::filesystem::exists(tmp("x.h5")));
  EXPECT_FALSE(std::filesystem::exists(tmp("y.h5")));
}
