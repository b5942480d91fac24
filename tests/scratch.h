#pragma once
// Each test's scratch folder, IRDM_TEST_TMP/<suite>.<test>. ctest runs tests in parallel, so
// two tests never share a file; and a test's folder is removed when it ends without a failure
// (RemoveScratchOfFinishedTests, installed by the test mains), so that a whole run needs the disk
// of the tests running at one time, not of all of them (a CI machine with a small disk once ran
// out). A failed test's files stay, to be looked at.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace irdm_test
{
  inline std::filesystem::path
  scratch_folder(const ::testing::TestInfo *test)
  {
    std::filesystem::path dir = IRDM_TEST_TMP;
    if (test != nullptr) // outside a test body (a static helper, say): the common folder
      dir /= std::string(test->test_suite_name()) + "." + test->name();
    return dir;
  }

  /// A path for `name` in the running test's own scratch folder (made if missing).
  inline std::string
  tmp(const std::string &name)
  {
    const auto dir = scratch_folder(::testing::UnitTest::GetInstance()->current_test_info());
    std::filesystem::create_directories(dir);
    return (dir / name).string();
  }

  class RemoveScratchOfFinishedTests : public ::testing::EmptyTestEventListener
  {
    void
    OnTestEnd(const ::testing::TestInfo &test) override
    {
      if (test.result()->Failed())
        return;
      std::error_code ignored; // a folder that cannot be removed only costs disk
      std::filesystem::remove_all(scratch_folder(&test), ignored);
    }
  };
} // namespace irdm_test
