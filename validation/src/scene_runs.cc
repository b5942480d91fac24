// Scene runs shared by the point validation and the compression study (scene_runs.h).
#include <reference_fem/elastodynamics.h>

#include <irdm_common/format.h>

#include <cmath>
#include <map>
#include <sstream>

#include "scene_runs.h"

namespace irdm::validation
{
  Errors
  compare(const Series &test, const Series &truth)
  {
    Errors e;
    double num = 0, den = 0, fpeak = 0, dmax = 0;
    const size_t N = std::min(test.force.empty() ? 0 : test.force[0].size(),
                                truth.force.empty() ? 0 : truth.force[0].size());
    for (size_t p = 0; p < truth.force.size(); ++p)
      for (size_t k = 0; k < truth.force[p].size(); ++k)
        fpeak = std::max(fpeak, norm(truth.force[p][k]));
    double upeak = 0;
    for (const auto &u : truth.surface)
      for (size_t j = 0; j + 2 < u.size(); j += 3)
        upeak = std::max(upeak, norm({u[j], u[j + 1], u[j + 2]}));
    e.force_t.assign(N, 0);
    e.disp_rms_t.assign(N, 0);
    double sum2 = 0;
    size_t count = 0;
    for (size_t k = 0; k < N; ++k)
      {
        for (size_t p = 0; p < truth.force.size(); ++p)
          {
            Vec3 d;
            for (int c = 0; c < 3; ++c)
              d[c] = test.force[p][k][c] - truth.force[p][k][c];
            num += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            den += std::pow(norm(truth.force[p][k]), 2);
            e.force_max = std::max(e.force_max, norm(d));
            e.force_t[k] = std::max(e.force_t[k], norm(d) / fpeak);
          }
        if (k >= test.surface.size() || k >= truth.surface.size())
          continue; // a force-only run: no displacement error
        double s2 = 0;
        const auto &a = test.surface[k], &b = truth.surface[k];
        for (size_t j = 0; j + 2 < b.size(); j += 3)
          {
            const double d = norm({a[j] - b[j], a[j + 1] - b[j + 1], a[j + 2] - b[j + 2]});
            s2 += d * d;
            dmax = std::max(dmax, d);
          }
        sum2 += s2;
        count += b.size() / 3;
        e.disp_rms_t[k] = std::sqrt(s2 / (b.size() / 3)) / upeak;
      }
    e.force_rel_l2 = std::sqrt(num / den);
    e.force_max /= fpeak;
    if (count > 0)
      {
        e.disp_rms = std::sqrt(sum2 / count) / upeak;
        e.disp_max = dmax / upeak;
      }
    return e;
  }

  Series
  run_fem(fem::Scene scene, const ModelFrame &model, const unsigned refine,
          const unsigned N)
  {
    scene.time_step /= refine;
    scene.outputs           = {};
    scene.outputs.surface   = true;
    scene.outputs.directory = "";
    fem::ElasticDynamics fem(scene);
    const auto           r = fem.run();
    std::map<long long, unsigned> index;
    for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
      index[r.surface.node_tags[i]] = i;
    Series s;
    s.step_seconds = r.stepping_seconds / r.n_steps;
    // The passivity observer at the FEM's own step (all of its steps, not only k tau).
    for (unsigned i = 1; i <= r.n_steps; ++i)
      for (const auto &p : scene.probes)
        {
          const double t = i * scene.time_step;
          observe_device_work(s, r.probe_force.at(p.name)[i], device_at(p, t),
                              device_at(p, t - scene.time_step));
        }
    for (const auto &p : scene.probes)
      {
        s.force.emplace_back();
        for (unsigned k = 1; k <= N; ++k)
          {
            Vec3 mean = {0, 0, 0};
            for (unsigned i = (k - 1) * refine + 1; i <= k * refine; ++i)
              for (int c = 0; c < 3; ++c)
                mean[c] += r.probe_force.at(p.name)[i][c] / refine;
            s.force.back().push_back(mean);
          }
      }
    for (unsigned k = 1; k <= N; ++k)
      {
        std::vector<double> u(model.n_outputs);
        for (unsigned v = 0; v < model.output_node_tags.size(); ++v)
          {
            const unsigned i = index.at(model.output_node_tags[v]);
            for (int d = 0; d < 3; ++d)
              u[3 * v + d] = r.surface_displacement[k * refine][3 * i + d];
          }
        s.surface.push_back(std::move(u));
      }
    return s;
  }

  double
  peak_force(const Series &s)
  {
    double peak = 0;
    for (const auto &p : s.force)
      for (const auto &f : p)
        peak = std::max(peak, norm(f));
    return peak;
  }

  bool
  coupling_bounded(const CouplingRun &r, const double reference_peak)
  {
    const double peak = peak_force(r.s);
    return r.s.diverged_at < 0 && std::isfinite(peak) && peak <= 100 * reference_peak;
  }

  bool
  coupling_passive(const CouplingRun &r, const double reference_peak)
  {
    return coupling_bounded(r, reference_peak) && r.s.device_returned <= 1e-6 * r.s.device_work_max;
  }

  std::string
  coupling_csv(const std::vector<CouplingRun> &runs, const double reference_peak)
  {
    std::ostringstream csv;
    csv << "stiffness_N_m,damping_N_s_m,time_step_s,solver,peak_force_N,device_work_J,"
           "device_work_max_J,device_returned_J,bounded,passive\n";
    for (const auto &r : runs)
      csv << r.k << "," << r.b << "," << r.tau << "," << r.solver << "," << peak_force(r.s) << ","
          << r.s.device_work << "," << r.s.device_work_max << "," << r.s.device_returned << ","
          << coupling_bounded(r, reference_peak) << "," << coupling_passive(r, reference_peak)
          << "\n";
    return csv.str();
  }

  std::string
  coupling_cell(const CouplingRun &r, const double reference_peak)
  {
    return std::string(coupling_passive(r, reference_peak)   ? "**P**"
                       : coupling_bounded(r, reference_peak) ? "**B**"
                                                             : "**D**") +
           " " + fmt(peak_force(r.s)) + " N, " + fmt(r.s.device_returned) + " J";
  }

  ProbeSurfaces
  probe_surfaces(const fem::Scene &scene, const ModelFrame &model)
  {
    ProbeSurfaces ps;
    for (const auto &probe : scene.probes)
      {
        const auto it = std::find(model.surface_names.begin(), model.surface_names.end(), probe.surface);
        if (it == model.surface_names.end())
          throw InputError("probe '" + probe.name + "': the model has no surface '" + probe.surface + "'");
        const int sid = static_cast<int>(it - model.surface_names.begin());
        ps.candidates.emplace_back();
        ps.triangles.emplace_back();
        for (unsigned t = 0; t < model.triangles.size(); ++t)
          if (model.triangle_surface[t] == sid)
            {
              ps.candidates.back().push_back(t);
              ps.triangles.back().push_back(model.triangles[t]);
            }
      }
    return ps;
  }
} // namespace irdm::validation
