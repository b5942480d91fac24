// The plane study's cases (plane_cases.h).
#include "plane_cases.h"

#include <irdm_common/error.h>
#include <irdm_common/format.h>

#include <algorithm>
#include <cmath>

namespace irdm::validation::planes
{
  namespace
  {
    /// "2", "10", "0.5": the case names' millimetres (a sweep goes below 1 mm).
    std::string
    millimetres(const double x)
    {
      return plain(std::round(x * 1e6) / 1000);
    }

    /// One wall along d, its penetration p(t) linear between (times, penetration).
    Case
    one_wall(const std::string &kind, const std::string &name, const Vec3 &d, const double depth,
             std::vector<double> times, std::vector<double> penetration, const double duration)
    {
      Case c;
      c.kind        = kind;
      c.name        = kind + "_" + name;
      c.d           = {d};
      c.depth       = depth;
      c.times       = std::move(times);
      c.penetration = std::move(penetration);
      c.duration    = duration;
      return c;
    }

    /// In over 0.2 s, held to 0.35 s, out by 0.45 s, free to 0.6 s.
    Case
    press(const std::string &side, const Vec3 &d, const double depth)
    {
      return one_wall("press_" + side, millimetres(depth) + "mm", d, depth, {0, 0.2, 0.35, 0.45},
                      {0, depth, depth, -0.01}, 0.6);
    }

    /// The wall arrives at the given speed, reverses at the depth, and leaves as fast.
    Case
    impact(const Vec3 &d, const double speed, const double depth)
    {
      const double t_in = depth / speed;
      Case         c    = one_wall("impact_side", millimetres(speed) + "mm_s", d, depth,
                                   {0, 0.004, 0.004 + t_in, 0.004 + 2 * t_in + 0.01 / speed},
                                   {-0.0001, 0, depth, -0.01}, 0.4);
      c.speed = speed;
      return c;
    }

    /// A wall on the side that turns from -angle to +angle about z while held at the depth,
    /// so that its contact patch slides over the surface: in over 0.1 s, turned by 0.45 s, out
    /// by 0.55 s, free to 0.6 s.
    Case
    slide(const Vec3 &d, const double depth, const double angle_deg)
    {
      Case c       = one_wall("slide_side", millimetres(depth) + "mm", d, depth, {0, 0.1, 0.45, 0.55},
                              {0, depth, depth, -0.01}, 0.6);
      c.turn_times = {0, 0.1, 0.45};
      c.turn_deg   = {-angle_deg, -angle_deg, angle_deg};
      return c;
    }
  } // namespace

  double
  interp(const std::vector<double> &t, const std::vector<double> &v, const double x)
  {
    if (x <= t.front())
      return v.front();
    if (x >= t.back())
      return v.back();
    const auto   i = std::upper_bound(t.begin(), t.end(), x) - t.begin();
    const double a = (x - t[i - 1]) / (t[i] - t[i - 1]);
    return (1 - a) * v[i - 1] + a * v[i];
  }

  Vec3
  direction(const Case &c, const std::size_t a, const double t)
  {
    if (c.turn_times.empty())
      return c.d[a];
    // Rodrigues: d cos + (k x d) sin + k (k . d)(1 - cos), k the unit axis.
    const double th = interp(c.turn_times, c.turn_deg, t) * M_PI / 180;
    const Vec3  &d = c.d[a], &k = c.turn_axis;
    const Vec3   kxd = {k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2], k[0] * d[1] - k[1] * d[0]};
    const double kd  = dot(k, d), co = std::cos(th), si = std::sin(th);
    Vec3         r;
    for (int i = 0; i < 3; ++i)
      r[i] = d[i] * co + kxd[i] * si + k[i] * kd * (1 - co);
    return r;
  }

  double
  wall_position(const Case &c, const VirtualDofModel &model, const std::size_t a, const double t)
  {
    const Vec3 d = direction(c, a, t);
    return dot(d, model.coordinates[surface_support(model, d).vertex]) -
           interp(c.times, c.penetration, t);
  }

  Directions
  case_directions(const VirtualDofModel &model)
  {
    const auto support_vertex = [&](const Vec3 &d) { return surface_support(model, d).vertex; };
    const auto centre = [&](const std::array<unsigned, 3> &t) {
      Vec3 c{0, 0, 0};
      for (const unsigned k : t)
        for (int a = 0; a < 3; ++a)
          c[a] += model.directions[k][a];
      const double n = std::sqrt(dot(c, c));
      return Vec3{c[0] / n, c[1] / n, c[2] / n};
    };
    Directions     r;
    const unsigned k_side = orientation_weights(model, r.side, OrientationMapping::nearest).k[0];
    for (const auto &t : model.dome_triangles)
      {
        const Vec3 c = centre(t);
        if ((t[0] == k_side || t[1] == k_side || t[2] == k_side) && c[2] > r.oblique[2])
          r.oblique = c;
        const unsigned v = support_vertex(c);
        if (support_vertex(model.directions[t[0]]) == v &&
            support_vertex(model.directions[t[1]]) == v &&
            support_vertex(model.directions[t[2]]) == v && dot(c, r.side) > dot(r.between, r.side))
          r.between = c;
      }
    if (r.between[1] < -1)
      throw InputError("validate-planes: no dome triangle whose virtual DOFs all first touch "
                       "the same vertex");
    return r;
  }

  std::vector<Case>
  plane_cases(const Directions &dirs, const bool quick)
  {
    using V                    = std::vector<double>;
    const V press_depths       = quick ? V{0.002, 0.005, 0.01} : V{0.002, 0.005, 0.01, 0.02};
    const V between_depths     = quick ? V{0.002, 0.01} : V{0.002, 0.005, 0.01, 0.02};
    const V speeds             = quick ? V{0.05, 0.1, 0.5} : V{0.05, 0.1, 0.2, 0.5};
    const V pair_depths        = quick ? V{0.005} : V{0.005, 0.01};
    std::vector<Case> cases;
    for (const double depth : press_depths)
      cases.push_back(press("side", dirs.side, depth));
    for (const double depth : {0.002, 0.005})
      cases.push_back(press("oblique", dirs.oblique, depth));
    for (const double depth : between_depths)
      cases.push_back(press("between", dirs.between, depth));
    for (const double depth : press_depths)
      cases.push_back(press("top", dirs.top, depth));
    for (const double speed : speeds)
      cases.push_back(impact(dirs.side, speed, 0.002));
    // Two walls at once, the same press on each: one on the top, one on the side.
    for (const double depth : pair_depths)
      {
        Case c = press("top_and_side", dirs.top, depth);
        c.d.push_back(dirs.side);
        cases.push_back(c);
      }
    // A tilted wall whose contact patch slides over the side: it turns 50 degrees about z.
    for (const double depth : pair_depths)
      cases.push_back(slide(dirs.side, depth, 25));
    return cases;
  }

  std::vector<Case>
  load_sweep(const Directions &dirs, const std::vector<std::string> &press_directions,
             const std::vector<double> &depths, const std::vector<double> &speeds)
  {
    std::vector<Case> cases;
    for (const std::string &side : press_directions)
      {
        const Vec3 *d = side == "top"       ? &dirs.top
                        : side == "side"    ? &dirs.side
                        : side == "between" ? &dirs.between
                        : side == "oblique" ? &dirs.oblique
                                            : nullptr;
        if (!d)
          throw InputError("no press direction '" + side + "' (top, side, between, oblique)");
        for (const double depth : depths)
          cases.push_back(press(side, *d, depth));
      }
    for (const double speed : speeds)
      cases.push_back(impact(dirs.side, speed, 0.002));
    return cases;
  }
} // namespace irdm::validation::planes
