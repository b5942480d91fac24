#pragma once
// Internal to validation/: the plane study's cases. Rigid walls press the grounded body, hit it
// and slide over it; each wall moves along a direction d into the undeformed body.
#include <irdm/plane_interaction.h>

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace irdm::validation::planes
{
  using Vec3 = std::array<double, 3>;

  inline double
  dot(const Vec3 &a, const Vec3 &b)
  {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  }

  /// v(x), linear between the samples (t, v), held beyond them.
  double
  interp(const std::vector<double> &t, const std::vector<double> &v, double x);

  /// One case: one or more walls, each along its d with its penetration p(t) into the
  /// undeformed body (m; the wall is at w = support(d) - p(t)), linear between samples.
  struct Case
  {
    std::string         kind, name;
    std::vector<Vec3>   d; // per wall, at t = 0
    double              depth = 0, speed = 0; // m, m/s (what is varied)
    std::vector<double> times, penetration;
    double              duration = 0;
    // A turning wall: d rotated about turn_axis by turn_deg(t) (degrees, linear between
    // turn_times); empty: d fixed.
    Vec3                turn_axis{0, 0, 1};
    std::vector<double> turn_times, turn_deg;
  };

  /// Wall a's direction at time t (unit).
  Vec3
  direction(const Case &c, std::size_t a, double t);

  /// Wall a's position w(t) along its direction: the free vertices' support minus p(t) (the
  /// fixed base belongs to the ground).
  double
  wall_position(const Case &c, const VirtualDofModel &model, std::size_t a, double t);

  /// The cases' directions. Side and top are dome directions. Oblique and between lie at the
  /// centres of two dome triangles, to measure what interpolating between orientations buys:
  /// - oblique: next to the side direction's nearest virtual DOF, the one with the highest
  ///   centre; there the first-contact vertex jumps between body parts from one virtual DOF to
  ///   the next (the cat is not convex);
  /// - between: one whose centre and three virtual DOFs all first touch the same vertex (of
  ///   those, the centre closest to the side direction).
  struct Directions
  {
    Vec3 side{0, 1, 0}, top{0, 0, 1}, oblique{0, 0, -2}, between{0, -2, 0};
  };

  Directions
  case_directions(const VirtualDofModel &model);

  /// Presses at the side, oblique, between and top directions, side impacts, two walls at once
  /// (top and side) and a sliding wall. `quick` keeps every kind of case and the compliant-wall
  /// sweep's cases, at fewer depths and speeds (no 20 mm press, one two-wall and one sliding
  /// depth, three impact speeds).
  std::vector<Case>
  plane_cases(const Directions &directions, bool quick);

  /// The nonlinear map's load sweeps, the same kinds of case: a press along each named
  /// direction (top, side, between, oblique) at each depth (m), and a side impact 2 mm deep at
  /// each speed (m/s).
  std::vector<Case>
  load_sweep(const Directions &directions, const std::vector<std::string> &press_directions,
             const std::vector<double> &depths, const std::vector<double> &speeds);
} // namespace irdm::validation::planes
