// Test main for the deal.II-free tests (no MPI or PETSc to initialise).
#include <gtest/gtest.h>

int
main(int argc, char **argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
