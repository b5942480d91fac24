// gmsh reader: the project's meshes read with their named surfaces; corrupt meshes are
// InputErrors that say what is wrong.
#include <irdm_common/error.h>
#include <reference_fem/mesh.h>

#include <gtest/gtest.h>

#include "scratch.h"

#include <filesystem>
#include <fstream>

using irdm::InputError;
using irdm::fem::read_gmsh;

namespace
{
  std::string
  write_tmp(const std::string &name, const std::string &text)
  {
    const std::string path = irdm_test::tmp(name);
    std::ofstream(path) << text;
    return path;
  }

  // One tetrahedron, its bottom face tagged "base"; `order` permutes its nodes.
  std::string
  one_tet(const std::string &tet_nodes, const std::string &z4 = "1")
  {
    return "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"base\"\n3 2 \"v\"\n"
           "$EndPhysicalNames\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 " + z4 +
           "\n$EndNodes\n$Elements\n2\n1 2 2 1 1 1 3 2\n2 4 2 2 1 " + tet_nodes +
           "\n$EndElements\n";
  }

  void
  expect_error(const std::string &path, const std::string &needle)
  {
    try
      {
        read_gmsh(path);
        ADD_FAILURE() << "no error for " << path;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      }
  }
} // namespace

TEST(Mesh, ProjectMeshesHaveTheirNamedSurfaces)
{
  const auto cat = read_gmsh(IRDM_MESH_DIR "/cat.msh");
  EXPECT_GT(cat.tets.size(), 2000u);
  EXPECT_LT(cat.tets.size(), 3000u);
  EXPECT_NO_THROW(cat.surface_tag("base"));
  EXPECT_NO_THROW(cat.surface_tag("skin"));
  const auto beam = read_gmsh(IRDM_MESH_DIR "/beam_2.msh");
  EXPECT_EQ(beam.tets.size(), 480u); // 2 x 2 x 20 hexahedra, 6 tetrahedra each
  double volume = 0;
  for (const auto &t : beam.tets)
    volume += irdm::fem::signed_volume(beam.vertices[t[0]], beam.vertices[t[1]],
                                       beam.vertices[t[2]], beam.vertices[t[3]]);
  EXPECT_NEAR(volume, 0.25 * 0.01 * 0.01, 1e-15);
}

TEST(Mesh, MissingNamedSurfaceListsTheNames)
{
  const auto beam = read_gmsh(IRDM_MESH_DIR "/beam_2.msh");
  try
    {
      beam.surface_tag("base");
      FAIL();
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("clamp"), std::string::npos) << e.what();
    }
}

TEST(Mesh, CorruptMeshesAreRejected)
{
  EXPECT_NO_THROW(read_gmsh(write_tmp("ok.msh", one_tet("1 2 3 4"))));
  expect_error(write_tmp("inverted.msh", one_tet("1 3 2 4")), "inverted");
  expect_error(write_tmp("flat.msh", one_tet("1 2 3 4", "0")), "degenerate");
  expect_error(write_tmp("missing_node.msh", one_tet("1 2 3 9")), "missing node");
  expect_error(write_tmp("garbage.msh", "hello\n"), "not a gmsh");
  expect_error(irdm_test::tmp("does_not_exist.msh"), "cannot open");
}
