#pragma once
// Precompute of the virtual degrees of freedom (seed 001): impulse responses to a rigid
// frictionless wall, one per plane orientation, with the geometrically nonlinear FEM.
//
// Orientation k is a unit direction d_k (a vertex of a geodesic dome); its wall is the plane
// {x : d_k . x = c} approaching the body along -d_k and pushing it along -d_k. Its first
// contact c_k = max over the body's surface vertices of d_k . X (undeformed).
//
// Discrete impulse (our convention, consistent with the point model's H): the wall touches
// during exactly one integrator step. From rest, the wall is away at t_0, at c_k - depth at
// t_1 (it penetrates the undeformed body by `impulse_depth`), and away again from t_2 on. The
// FEM's penalty contact then gives one force sample F_k (N, the resultant along -d_k) at step
// 1, entering the integrator as any load sample does. Responses are divided by F_k:
//   surface response S_k[s] = u_surface(t_{1+s}) / F_k   (m/N, s = 0..T-1; S_k[0] is the
//                                                         feed-through),
//   virtual DOF response Y_jk[s] = y_j(t_{1+s}) / F_k     (m/N),
// where y_j, the displacement on virtual DOF j, is the mean over the surface vertices within
// `band` of plane j at its first contact (d_j . X >= c_j - band) of -d_j . u: how far the
// surface there has receded from wall j. At run time a wall force history f_k[n] (N along
// -d_k during step n) gives y[n] = sum_s Y[s] f[n - s] and the surface likewise.
//
// A free body (a scene with no fixed surface; issue 14, route 1 of the seed): the wall's hit
// also sends the body away rigidly. At every sample the rigid part is taken out and S and Y
// record what is left, in that frame: the translation of the centre of mass (from the FEM:
// mass weights, because the run-time rigid body carries the whole impulse and the deformation
// may then carry no momentum; with uniform weights over the surface, the dent of the hit
// region would pull the fitted translation and the run-time contact force would be a few
// percent off), and the best rotation about it over the surface vertices (the seed's
// "corresponding nodes", Kabsch: exact at any angle; irdm_common/rigid_fit.h). The run-time
// rigid body makes the motion (irdm/free_body.h). The file then says body = free,
// free_body_route = rigid_fit and stores the mass, centre of mass and inertia (format 3).
//
// Runs under mpirun: orientations are dealt to ranks (k % size), rank 0 writes the file.
#include <reference_fem/scene.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace irdm::fem
{
  /// Unit vectors at the vertices of an icosahedron with a vertex at +z, each face subdivided
  /// `subdivisions` times (10 * 4^s + 2 vertices: 162 for s = 2), and the dome's triangles.
  struct GeodesicDome
  {
    std::vector<Vec3>                    directions;
    std::vector<std::array<unsigned, 3>> triangles;
  };
  GeodesicDome
  geodesic_dome(unsigned subdivisions);

  struct VirtualDofOptions
  {
    std::string             output;              // model file (.h5)
    unsigned                subdivisions   = 2;  // 162 orientations
    double                  impulse_depth  = 0.001; // m, the wall's penetration at step 1
    double                  band           = 0.001; // m, the seed's +-1 mm
    std::optional<unsigned> length;              // T; default scene.model.length
    std::optional<bool>     double_storage;      // default scene.model.storage
    bool allow_large = false; // run even if the memory or disk estimate exceeds what is free
    std::function<void(const std::string &)> log; // progress lines (rank 0)
  };

  struct VirtualDofReport
  {
    unsigned n_orientations = 0, n_surface = 0, length = 0;
    int      ranks = 1;
    double   seconds_total = 0;
    double   seconds_per_orientation_mean = 0, seconds_per_orientation_max = 0; // FEM runs
    double   impulse_force_min = 0, impulse_force_max = 0;                      // N
    unsigned newton_iterations = 0;
    bool     free_body = false;
    // Free body: the rigid motion the fit took out, as a share of the recorded displacement
    // (RMS over the surface, largest over the samples; mean and largest over orientations).
    double rigid_share_mean = 0, rigid_share_max = 0;
  };

  /// Collective over MPI_COMM_WORLD. Throws InputError for a bad option.
  VirtualDofReport
  precompute_virtual_dofs(const Scene &scene, const VirtualDofOptions &options);
} // namespace irdm::fem
