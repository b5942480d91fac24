// The irdm program as a user meets it: options refused rather than truncated, a full disk
// during simulate (exit 4, nothing under the final name), inputs never overwritten, commands
// that are not parallel refused under mpirun. Runs the real binary (IRDM_CLI).
#include <irdm/model.h>
#include <reference_fem/mesh.h>

#include "irdm_test_util.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include <sys/wait.h>

using namespace irdm_test;

namespace
{
  // Exit status of a shell command run with a clean environment (no MPI variables of ours).
  int
  status(const std::string &cmd)
  {
    const std::string clean = "env -i PATH=/usr/bin:/bin HOME=/tmp ";
    const int s = std::system((clean + "bash -c '" + cmd + "' > /dev/null 2>&1").c_str());
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

TEST(Cli, CommandsThatAreNotParallelAreRefusedUnderMpirun)
{
  if (std::system("command -v mpirun > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "mpirun not installed";
  EXPECT_EQ(status("mpirun --allow-run-as-root --oversubscribe -np 2 " + std::string(IRDM_CLI) +
                   " modes " + write_scene("cli_mpi", "") + " --count 2"),
            2);
}
