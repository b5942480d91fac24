// The irdm program as a user meets it: options refused rather than truncated, a full disk
// during simulate (exit 4, nothing under the final name), inputs never overwritten, commands
// that are not parallel refused under mpirun. Runs the real binary (IRDM_CLI).
#include <irdm/model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/mesh.h>

#include "irdm_test_util.h"

#include <gtest/gtest.h>

#include <cmath>

#include <cstdlib>
#include <fstream>
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

TEST(Cli, PrecomputeAndCompressOnAFullDiskExitFourAndLeaveNoResult)
{
  // The beam's model is 40 MB and, at theta 0.999, its compressed model about 12 MB: both
  // larger than a 7 MiB file-size limit (MPI's start-up needs about 6 MiB itself).
  const std::string full = "ulimit -f 7168; trap \"\" XFSZ; " + std::string(IRDM_CLI);
  const std::string scene = write_scene("cli_full_pc", "");
  const std::string model = tmp("cli_full_model.h5"), compressed = tmp("cli_full_c.h5");
  for (const auto &f : {model, compressed, model + ".part", compressed + ".part"})
    fs::remove(f);
  EXPECT_EQ(status(full + " precompute " + scene + " --out " + model + " --chunk 10 --quiet"), 4);
  EXPECT_FALSE(fs::exists(model));
  // With room, the run completes (the part file of the failed run is not trusted).
  EXPECT_EQ(status(std::string(IRDM_CLI) + " precompute " + scene + " --out " + model +
                   " --chunk 10 --quiet"),
            0);
  ASSERT_GT(fs::file_size(model), 7168u * 1024u);
  const std::string compress = " compress " + model + " --out " + compressed + " --theta 0.999 --quiet";
  EXPECT_EQ(status(full + compress), 4);
  EXPECT_FALSE(fs::exists(compressed));
  EXPECT_FALSE(fs::exists(compressed + ".part"));
  EXPECT_EQ(status(std::string(IRDM_CLI) + compress), 0);
  EXPECT_GT(fs::file_size(compressed), 7168u * 1024u);
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
  // beam_4: its modes take seconds, so the first run still holds the output's lock when the
  // second starts (the script waits for the lock file first).
  std::string text = beam_scene("");
  text.replace(text.find("beam_2.msh"), 10, "beam_4.msh");
  const std::string scene = tmp("cli_concurrent.json"), out = tmp("cli_concurrent.h5"),
                    result = tmp("cli_concurrent.txt"), script = tmp("cli_concurrent.sh");
  std::ofstream(scene) << text;
  for (const auto &f : {out, out + ".part", out + ".lock", result})
    fs::remove(f);
  const std::string run = std::string(IRDM_CLI) + " precompute " + scene + " --out " + out +
                          " --quiet > /dev/null 2>&1";
  std::ofstream(script) << run << " &\nfirst=$!\n"
                        << "while [ ! -e " << out << ".lock ] && kill -0 $first 2> /dev/null; do "
                        << "sleep 0.02; done\n"
                        << run << "\nsecond=$?\nwait $first\necho $? $second > " << result << "\n";
  ASSERT_EQ(status("bash " + script), 0);
  std::ifstream in(result);
  int           first_status = -1, second_status = -1;
  in >> first_status >> second_status;
  EXPECT_EQ(second_status, 2) << "the second run must be refused";
  EXPECT_EQ(first_status, 0) << "the first run must finish undisturbed";
  EXPECT_NO_THROW(load_model(out)); // complete: every chunk written by the first run
  EXPECT_FALSE(fs::exists(out + ".lock"));
}

TEST(Cli, ValidateNeverTouchesAModelAlreadyInItsModelsFolder)
{
  const std::string scenes = tmp("cli_validate_scenes"), models = tmp("cli_validate_models");
  fs::remove_all(scenes);
  fs::remove_all(models);
  fs::create_directories(scenes);
  fs::create_directories(models);
  std::ofstream(fs::path(scenes) / "irdm_beam.json") << beam_scene("");
  const std::string mine = (fs::path(models) / "irdm_beam.h5").string();
  std::ofstream(mine) << "a user's file";
  EXPECT_EQ(status(std::string(IRDM_CLI) + " validate --scenes " + scenes + " --models " + models +
                   " --out " + tmp("cli_validate_report") + " --no-full-model"),
            2);
  std::ifstream in(mine);
  std::string   content;
  std::getline(in, content);
  EXPECT_EQ(content, "a user's file");
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
  std::ifstream csv(fs::path(dir) / "summary.csv");
  std::string   header, row;
  ASSERT_TRUE(std::getline(csv, header) && std::getline(csv, row));
  std::map<std::string, double> v;
  std::stringstream             h(header), r(row);
  for (std::string name, value; std::getline(h, name, ',') && std::getline(r, value, ',');)
    v[name] = std::stod(value);
  EXPECT_EQ(v["steps"], 100);
  EXPECT_EQ(v["missed"], v["missed_step_overrun"] + v["missed_woken_late"]);
  EXPECT_GE(v["baseline_missed"], 0); // the baseline ran
  EXPECT_LE(v["baseline_missed"], 100);
  EXPECT_GT(v["peak_force_N"], 1e-4); // the probe pressed the beam
  EXPECT_GE(v["force_error"], 0);
  EXPECT_LT(v["force_error"], 1e-12);
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
