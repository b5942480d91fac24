// The main of every test binary. Those that link deal.II (IRDM_TEST_MPI) initialise PETSc/MPI
// once per process; those with a scratch folder (IRDM_TEST_TMP) remove a test's folder when the
// test passes (scratch.h).
#ifdef IRDM_TEST_MPI
#  include <deal.II/base/mpi.h>
#endif

#include <gtest/gtest.h>

#ifdef IRDM_TEST_TMP
#  include "scratch.h"
#endif

int
main(int argc, char **argv)
{
#ifdef IRDM_TEST_MPI
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
#endif
  ::testing::InitGoogleTest(&argc, argv);
#ifdef IRDM_TEST_TMP
  ::testing::UnitTest::GetInstance()->listeners().Append(
    new irdm_test::RemoveScratchOfFinishedTests); // gtest owns and deletes it
#endif
  return RUN_ALL_TESTS();
}
