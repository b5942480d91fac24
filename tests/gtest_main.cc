// PETSc/MPI (linked through deal.II) must be initialised once per test process.
#include <deal.II/base/mpi.h>

#include <gtest/gtest.h>

#ifdef IRDM_TEST_TMP
#  include "scratch.h"
#endif

int
main(int argc, char **argv)
{
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  ::testing::InitGoogleTest(&argc, argv);
#ifdef IRDM_TEST_TMP
  ::testing::UnitTest::GetInstance()->listeners().Append(
    new irdm_test::RemoveScratchOfFinishedTests); // gtest owns and deletes it
#endif
  return RUN_ALL_TESTS();
}
