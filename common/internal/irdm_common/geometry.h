#pragma once
// Closest point on a triangle mesh, by barycentric weights: the contact point of a probe
// between vertices; and the contact patch of a probe with a radius. Shared by the reference FEM
// and the IRDM runtime so both place a probe identically. Allocation-free.
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

namespace irdm::geometry
{
  using Point = std::array<double, 3>;

  struct SurfacePoint
  {
    int                   triangle = -1; // index into the triangle list
    std::array<double, 3> weights  = {0, 0, 0}; // barycentric, sum 1, each >= 0
    Point                 point    = {0, 0, 0};
    double                distance_squared = std::numeric_limits<double>::infinity();
  };

  /// Closest point to p on triangle (a, b, c) as barycentric weights (Ericson, Real-Time
  /// Collision Detection, 5.1.5: region tests on the Voronoi regions of the triangle).
  inline std::array<double, 3>
  closest_on_triangle(const Point &p, const Point &a, const Point &b, const Point &c)
  {
    const auto sub = [](const Point &x, const Point &y) {
      return Point{x[0] - y[0], x[1] - y[1], x[2] - y[2]};
    };
    const auto dot = [](const Point &x, const Point &y) {
      return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    };
    const Point  ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0)
      return {1, 0, 0};
    const Point  bp = sub(p, b);
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3)
      return {0, 1, 0};
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0)
      {
        const double v = d1 / (d1 - d3);
        return {1 - v, v, 0};
      }
    const Point  cp = sub(p, c);
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6)
      return {0, 0, 1};
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0)
      {
        const double w = d2 / (d2 - d6);
        return {1 - w, 0, w};
      }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
      {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return {0, 1 - w, w};
      }
    const double denom = 1 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return {1 - v - w, v, w};
  }

  /// Closest point to p over the triangles (brute force; ties keep the first triangle).
  /// Vertices: any indexable of Point; Triangles: any indexable of 3 vertex indices.
  template <typename Vertices, typename Triangles>
  SurfacePoint
  closest_point(const Vertices &vertices, const Triangles &triangles, const Point &p)
  {
    SurfacePoint best;
    for (std::size_t t = 0; t < triangles.size(); ++t)
      {
        const Point &a = vertices[triangles[t][0]], &b = vertices[triangles[t][1]],
                    &c = vertices[triangles[t][2]];
        const auto w = closest_on_triangle(p, a, b, c);
        Point      q;
        double     d2 = 0;
        for (int d = 0; d < 3; ++d)
          {
            q[d] = w[0] * a[d] + w[1] * b[d] + w[2] * c[d];
            d2 += (q[d] - p[d]) * (q[d] - p[d]);
          }
        if (d2 < best.distance_squared)
          best = SurfacePoint{static_cast<int>(t), w, q, d2};
      }
    return best;
  }

  /// The contact patch of a probe with a contact radius r centred at the surface point c: the
  /// surface vertices within distance r of c, with weights
  ///   w_i = A_i psi(|x_i - c| / r) / sum_j A_j psi(|x_j - c| / r),  psi(rho) = (1 - rho^2)^2,
  /// A_i a third of the area of the given triangles at vertex i (a lumped quadrature of the
  /// surface). The probe's force F spreads as w_i F, and the probe's displacement is
  /// sum_i w_i u_i (the same weights: force and displacement stay work-conjugate). As the mesh
  /// is refined this tends to the smooth traction F psi / (integral of psi) on a disc, whose
  /// compliance is finite; a force on one vertex (a point load) has a compliance that grows
  /// without bound as the mesh is refined. psi is C1 at rho = 1, so a patch that slides over the
  /// surface changes its weights continuously.
  /// Writes up to max_n (vertex, weight) pairs and returns their number; returns -1 if more
  /// than max_n vertices lie within r, and 0 if none does (then r is below the mesh size).
  template <typename Vertices, typename Triangles>
  int
  radius_patch(const Vertices &vertices, const Triangles &triangles, const Point &c,
               const double r, unsigned *vertex, double *weight, const int max_n)
  {
    int n = 0;
    for (std::size_t t = 0; t < triangles.size(); ++t)
      {
        const Point &a = vertices[triangles[t][0]], &b = vertices[triangles[t][1]],
                    &d = vertices[triangles[t][2]];
        const Point ab = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const Point ad = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        const Point cross = {ab[1] * ad[2] - ab[2] * ad[1], ab[2] * ad[0] - ab[0] * ad[2],
                             ab[0] * ad[1] - ab[1] * ad[0]};
        const double third_area =
          std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]) / 6;
        for (int k = 0; k < 3; ++k)
          {
            const unsigned v   = static_cast<unsigned>(triangles[t][k]);
            const Point   &x   = vertices[v];
            const double   rho2 = ((x[0] - c[0]) * (x[0] - c[0]) + (x[1] - c[1]) * (x[1] - c[1]) +
                                 (x[2] - c[2]) * (x[2] - c[2])) /
                                (r * r);
            if (!(rho2 < 1))
              continue;
            const double psi = (1 - rho2) * (1 - rho2);
            int          i   = 0;
            while (i < n && vertex[i] != v)
              ++i;
            if (i == n)
              {
                if (n == max_n)
                  return -1;
                vertex[n]   = v;
                weight[n++] = 0;
              }
            weight[i] += third_area * psi;
          }
      }
    double sum = 0;
    for (int i = 0; i < n; ++i)
      sum += weight[i];
    for (int i = 0; i < n; ++i)
      weight[i] /= sum;
    return n;
  }
} // namespace irdm::geometry
