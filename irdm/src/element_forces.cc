#include "element_forces.h"

#include "surface_product.h" // surface_product_avx2_available

#include <cmath>

namespace irdm::detail
{
  namespace
  {
#define IRDM_LANES inline __attribute__((always_inline))

    // Four doubles, one per element. Its operations are loops over the lanes, which the
    // compiler makes one vector instruction each; always inlined, so that the AVX2 entry point
    // compiles them with 256-bit vectors.
    struct alignas(32) Lanes
    {
      double x[4];
    };

    IRDM_LANES Lanes
    operator+(Lanes a, const Lanes &b)
    {
      for (int l = 0; l < 4; ++l)
        a.x[l] += b.x[l];
      return a;
    }
    IRDM_LANES Lanes
    operator-(Lanes a, const Lanes &b)
    {
      for (int l = 0; l < 4; ++l)
        a.x[l] -= b.x[l];
      return a;
    }
    IRDM_LANES Lanes
    operator*(Lanes a, const Lanes &b)
    {
      for (int l = 0; l < 4; ++l)
        a.x[l] *= b.x[l];
      return a;
    }
    IRDM_LANES Lanes
    operator*(const double s, Lanes a)
    {
      for (int l = 0; l < 4; ++l)
        a.x[l] *= s;
      return a;
    }
    IRDM_LANES Lanes
    load(const double *p)
    {
      Lanes a;
      for (int l = 0; l < 4; ++l)
        a.x[l] = p[l];
      return a;
    }

    using Lanes33 = Lanes[3][3];

    // grad w (3 x 3) of nodal vectors w (3 per vertex): W(a, b) = sum_i w_i(a) g_i(b).
    IRDM_LANES void
    nodal_gradient(const ElementLanes &e, const double *w, Lanes33 &W)
    {
      Lanes n[4][3]; // node i's component a, per lane
      for (int l = 0; l < 4; ++l)
        for (int i = 0; i < 4; ++i)
          for (int a = 0; a < 3; ++a)
            n[i][a].x[l] = w[3 * std::size_t(e.vertex[l][i]) + a];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          W[a][b] = n[0][a] * load(e.grad[b][0]) + n[1][a] * load(e.grad[b][1]) +
                    n[2][a] * load(e.grad[b][2]) + n[3][a] * load(e.grad[b][3]);
    }

    // The kernel, as neo_hookean_stress and damped_neo_hookean_force (neo_hookean_tet.h) write
    // it: J - 1 from H, A = F^-T = cof(F) / det F, P = mu (H + H^T A) + lambda ln J A, plus beta F S_d
    // with S_d = lambda tr(E') I + 2 mu E', E' = sym(F^T grad v); node i's force V P g_i.
    template <bool damped>
    IRDM_LANES unsigned
    forces(const ElementLanes *groups, const std::size_t n_groups, const double *u, const double *v,
           const double mu, const double lambda, const double beta, double *f)
    {
      unsigned inverted = 0;
      for (std::size_t k = 0; k < n_groups; ++k)
        {
          const ElementLanes &e = groups[k];
          Lanes33             H;
          nodal_gradient(e, u, H);
          const Lanes tH  = H[0][0] + H[1][1] + H[2][2];
          Lanes       tHH = H[0][0] * H[0][0];
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              if (a + b > 0)
                tHH = tHH + H[a][b] * H[b][a];
          const Lanes detH = H[0][0] * (H[1][1] * H[2][2] - H[1][2] * H[2][1]) -
                             H[0][1] * (H[1][0] * H[2][2] - H[1][2] * H[2][0]) +
                             H[0][2] * (H[1][0] * H[2][1] - H[1][1] * H[2][0]);
          const Lanes J_minus_1 = tH + 0.5 * (tH * tH - tHH) + detH;
          Lanes       lnJ;
          bool        ok[4];
          for (int l = 0; l < 4; ++l)
            {
              ok[l]    = J_minus_1.x[l] > -1;
              lnJ.x[l] = ok[l] ? std::log1p(J_minus_1.x[l]) : 0.0;
            }
          Lanes33 F;
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              F[a][b] = a == b ? H[a][b] + Lanes{{1, 1, 1, 1}} : H[a][b];
          // cof(F)(a, b) = F(a+1, b+1) F(a+2, b+2) - F(a+1, b+2) F(a+2, b+1), indices mod 3.
          Lanes33 A;
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              {
                const int a1 = (a + 1) % 3, a2 = (a + 2) % 3, b1 = (b + 1) % 3, b2 = (b + 2) % 3;
                A[a][b] = F[a1][b1] * F[a2][b2] - F[a1][b2] * F[a2][b1];
              }
          const Lanes det = F[0][0] * A[0][0] + F[0][1] * A[0][1] + F[0][2] * A[0][2];
          Lanes       inv;
          for (int l = 0; l < 4; ++l)
            inv.x[l] = ok[l] ? 1 / det.x[l] : 0.0; // an inverted lane's force is left out
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              A[a][b] = A[a][b] * inv;
          Lanes33 P;
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              P[a][b] = mu * (H[a][b] + H[0][a] * A[0][b] + H[1][a] * A[1][b] + H[2][a] * A[2][b]) +
                        lambda * (lnJ * A[a][b]);
          if constexpr (damped)
            {
              Lanes33 G, E;
              nodal_gradient(e, v, G);
              for (int a = 0; a < 3; ++a) // F^T grad v
                for (int b = 0; b < 3; ++b)
                  E[a][b] = F[0][a] * G[0][b] + F[1][a] * G[1][b] + F[2][a] * G[2][b];
              const Lanes trE = E[0][0] + E[1][1] + E[2][2];
              Lanes33     S;
              for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                  {
                    S[a][b] = mu * (E[a][b] + E[b][a]); // 2 mu sym(E)
                    if (a == b)
                      S[a][b] = S[a][b] + lambda * trE;
                  }
              for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                  P[a][b] = P[a][b] + beta * (F[a][0] * S[0][b] + F[a][1] * S[1][b] + F[a][2] * S[2][b]);
            }
          const Lanes w = load(e.weight_volume);
          Lanes       fi[4][3];
          for (int i = 0; i < 4; ++i)
            for (int a = 0; a < 3; ++a)
              fi[i][a] = w * (P[a][0] * load(e.grad[0][i]) + P[a][1] * load(e.grad[1][i]) +
                              P[a][2] * load(e.grad[2][i]));
          for (int l = 0; l < e.lanes; ++l)
            {
              if (!ok[l])
                {
                  ++inverted;
                  continue;
                }
              for (int i = 0; i < 4; ++i)
                for (int a = 0; a < 3; ++a)
                  f[3 * std::size_t(e.vertex[l][i]) + a] += fi[i][a].x[l];
            }
        }
      return inverted;
    }
#undef IRDM_LANES
  } // namespace

  std::vector<ElementLanes>
  pack_element_lanes(const std::vector<elastic::Tetrahedron>   &elements,
                     const std::vector<double>                 &weights,
                     const std::vector<std::array<unsigned, 4>> &vertices)
  {
    std::vector<ElementLanes> groups((elements.size() + 3) / 4);
    for (std::size_t k = 0; k < elements.size(); ++k)
      {
        ElementLanes &e = groups[k / 4];
        const int     l = static_cast<int>(k % 4);
        for (int b = 0; b < 3; ++b)
          for (int i = 0; i < 4; ++i)
            e.grad[b][i][l] = elements[k].grad(b, i);
        e.weight_volume[l] = weights[k] * elements[k].volume;
        e.vertex[l]        = vertices[k];
        e.lanes            = l + 1;
      }
    for (auto &e : groups) // padding: a lane at the first element's vertices, no gradient, no weight
      for (int l = e.lanes; l < 4; ++l)
        {
          for (int b = 0; b < 3; ++b)
            for (int i = 0; i < 4; ++i)
              e.grad[b][i][l] = 0;
          e.weight_volume[l] = 0;
          e.vertex[l]        = e.vertex[0];
        }
    return groups;
  }

  unsigned
  damped_neo_hookean_forces_portable(const ElementLanes *groups, const std::size_t n_groups,
                                     const double *u, const double *v, const double mu,
                                     const double lambda, const double beta, double *f)
  {
    return beta != 0 ? forces<true>(groups, n_groups, u, v, mu, lambda, beta, f)
                     : forces<false>(groups, n_groups, u, v, mu, lambda, beta, f);
  }

#if defined(__x86_64__) && defined(__GNUC__)
  __attribute__((target("avx2,fma"))) unsigned
  damped_neo_hookean_forces_avx2(const ElementLanes *groups, const std::size_t n_groups,
                                 const double *u, const double *v, const double mu,
                                 const double lambda, const double beta, double *f)
  {
    return beta != 0 ? forces<true>(groups, n_groups, u, v, mu, lambda, beta, f)
                     : forces<false>(groups, n_groups, u, v, mu, lambda, beta, f);
  }
#else
  unsigned
  damped_neo_hookean_forces_avx2(const ElementLanes *groups, const std::size_t n_groups,
                                 const double *u, const double *v, const double mu,
                                 const double lambda, const double beta, double *f)
  {
    return damped_neo_hookean_forces_portable(groups, n_groups, u, v, mu, lambda, beta, f);
  }
#endif

  unsigned
  damped_neo_hookean_forces(const ElementLanes *groups, const std::size_t n_groups,
                            const double *u, const double *v, const double mu,
                            const double lambda, const double beta, double *f)
  {
    static const bool avx2 = surface_product_avx2_available(); // thread-safe, decided once
    return avx2 ? damped_neo_hookean_forces_avx2(groups, n_groups, u, v, mu, lambda, beta, f)
                : damped_neo_hookean_forces_portable(groups, n_groups, u, v, mu, lambda, beta, f);
  }
} // namespace irdm::detail
