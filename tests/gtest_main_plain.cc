// Test main for the deal.II-free tests (no MPI or PETSc to initialise).
#include <gtest/gtest.h>

#ifdef IRDM_TEST_TMP
#  include "scratch.h"
#endif

int
main(int argc, char **argv)
{
  ::testing::InitGoogleTest(&argc, argv);
#ifdef IRDM_TEST_TMP
  ::testing::UnitTest::GetInstance()->listeners().Append(
    new irdm_test::RemoveScratchOfFinishedTests); // gtest owns and deletes it
#endif
  return RUN_ALL_TESTS();
}
