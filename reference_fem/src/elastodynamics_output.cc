// ElasticDynamics outputs: HDF5 (layout in docs/fem-output.md), CSV, VTU time series.
#include <deal.II/base/data_out_base.h>
#include <deal.II/numerics/data_out.h>

#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include "elastodynamics_impl.h"

#include <filesystem>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace irdm::fem
{
  namespace fs = std::filesystem;

  namespace
  {
    std::vector<double>
    flatten(const std::vector<Vec3> &series)
    {
      std::vector<double> out;
      out.reserve(3 * series.size());
      for (const auto &v : series)
        out.insert(out.end(), v.begin(), v.end());
      return out;
    }

    // The map's keys in the order the scene lists them (CSV columns follow the scene, not the
    // alphabet), then any others.
    template <typename Map>
    std::vector<std::string>
    in_scene_order(const Map &m, const std::vector<std::string> &order)
    {
      std::vector<std::string> out;
      const auto               listed = [&](const std::string &k) {
        return std::find(out.begin(), out.end(), k) != out.end();
      };
      for (const auto &k : order)
        if (m.count(k) && !listed(k))
          out.push_back(k);
      for (const auto &kv : m)
        if (!listed(kv.first))
          out.push_back(kv.first);
      return out;
    }

    const char *
    integrator_name(const Scene &s)
    {
      return s.integrator == Integrator::newmark ? "newmark_average_acceleration"
                                                 : "generalized_alpha";
    }
  } // namespace

  void
  clear_samples(RunResult &r)
  {
    r.time.clear();
    r.kinetic_energy.clear();
    r.strain_energy.clear();
    for (auto *m : {&r.vertex_displacement, &r.probe_displacement, &r.probe_force,
                    &r.probe_contact_point, &r.fixed_reaction, &r.plane_force})
      for (auto &kv : *m)
        kv.second.clear();
    for (auto &kv : r.probe_active)
      kv.second.clear();
    for (auto &kv : r.plane_penetration)
      kv.second.clear();
    r.contact_energy.clear();
    r.gravity_energy.clear();
    r.linear_momentum.clear();
    r.center_of_mass_displacement.clear();
    r.largest_strain.clear();
    r.strained_volume_fraction.clear();
    r.surface_displacement.clear();
    r.field_displacement.clear();
  }

  unsigned
  n_samples(const Scene &scene)
  {
    const unsigned N = scene.n_steps(), every = scene.outputs.every;
    return 1 + N / every + (N % every != 0 ? 1 : 0);
  }

  struct ResultWriter::Impl
  {
    const Scene &scene;
    unsigned     n_dofs = 0;
    hsize_t      N = 0, written = 0;
    std::string  base;
    OutputLock   lock; // "<base>.lock": the CSV files; the HDF5 writer holds its own
    std::unique_ptr<h5::Writer> h5;
    std::FILE   *series = nullptr, *surface = nullptr;
    std::vector<std::string> vertices, probes, fixed, planes; // series, in scene order
    bool         started = false;

    Impl(const Scene &s, const unsigned dofs, const unsigned n)
      : scene(s)
      , n_dofs(dofs)
      , N(n)
      , base((fs::path(s.outputs.directory) / s.name).string())
      , lock(base)
    {}

    ~Impl()
    {
      // Not finished: nothing may carry a final name (the HDF5 writer removes its part).
      for (auto *f : {series, surface})
        if (f)
          std::fclose(f);
      if (series)
        std::remove((base + "_series.csv.part").c_str());
      if (surface)
        std::remove((base + "_surface.csv.part").c_str());
    }

    std::FILE *
    open_csv(const std::string &path) const
    {
      std::FILE *f = std::fopen((path + ".part").c_str(), "wb");
      if (!f)
        throw IoError("cannot create '" + path + ".part': " + std::strerror(errno));
      return f;
    }

    static void
    check(const bool ok, const std::string &path)
    {
      if (!ok)
        throw IoError("cannot write '" + path + "': " + std::strerror(errno));
    }

    // A dataset of N rows written in batches; chunks of about 1 MB.
    void
    dataset(const std::string &name, std::vector<hsize_t> dims)
    {
      hsize_t row = 1;
      for (size_t i = 1; i < dims.size(); ++i)
        row *= dims[i];
      h5->create_dataset(name, dims, true, std::max<hsize_t>(1, 131072 / row));
    }

    void
    start(const RunResult &r)
    {
      vertices = in_scene_order(r.vertex_displacement, [&] {
        std::vector<std::string> v;
        for (const auto &o : scene.outputs.vertices)
          v.push_back(o.name);
        return v;
      }());
      probes = in_scene_order(r.probe_force, [&] {
        std::vector<std::string> v;
        for (const auto &p : scene.prescribed)
          v.push_back(p.name);
        for (const auto &p : scene.probes)
          v.push_back(p.name);
        return v;
      }());
      fixed  = in_scene_order(r.fixed_reaction, scene.fixed_surfaces);
      planes = in_scene_order(r.plane_force, [&] {
        std::vector<std::string> v;
        for (const auto &p : scene.planes)
          v.push_back(p.name);
        return v;
      }());
      const bool contact = !r.contact_energy.empty();
      const hsize_t nv   = r.surface.node_tags.size();

      if (scene.outputs.hdf5)
        {
          h5 = std::make_unique<h5::Writer>(base + ".h5");
          auto &w = *h5;
          w.attribute("/", "format", std::string("irdm-fem-result/1"));
          w.attribute("/", "units", std::string("SI: m, s, N, kg, Pa, J"));
          w.attribute("/", "program_version", std::string(IRDM_VERSION));
          w.attribute("/", "scene_json", scene.json_text);
          w.attribute("/", "mesh_file", scene.mesh_file);
          w.attribute("/", "mesh_fnv1a64", file_hash(scene.mesh_file));
          w.attribute("/", "fe_degree", static_cast<long long>(scene.fe_degree));
          w.attribute("/", "n_dofs", static_cast<long long>(n_dofs));
          w.attribute("/", "youngs_modulus_Pa", scene.youngs_modulus);
          w.attribute("/", "poisson_ratio", scene.poisson_ratio);
          w.attribute("/", "density_kg_m3", scene.density);
          w.attribute("/", "rayleigh_alpha_1_s", scene.rayleigh_alpha);
          w.attribute("/", "rayleigh_beta_s", scene.rayleigh_beta);
          w.attribute("/", "integrator", std::string(integrator_name(scene)));
          w.attribute("/", "rho_inf", scene.rho_inf);
          w.attribute("/", "time_step_s", scene.time_step);
          w.attribute("/", "kinematics",
                      std::string(scene.kinematics == Kinematics::linear ? "linear"
                                  : scene.body_frame_law
                                    ? "nonlinear (Total Lagrangian, small-strain law in the body frame)"
                                  : scene.small_strain_law
                                    ? "nonlinear (Total Lagrangian, small-strain law)"
                                  : scene.corotational_law
                                    ? "nonlinear (Total Lagrangian, corotational small-strain law)"
                                    : "nonlinear (Total Lagrangian neo-Hookean)"));
          dataset("/time", {N});
          w.create_group("/energy");
          dataset("/energy/kinetic", {N});
          dataset("/energy/strain", {N});
          if (contact)
            {
              dataset("/energy/contact", {N});
              dataset("/energy/gravity", {N});
            }
          const auto group = [&](const std::string &g, const std::vector<std::string> &names) {
            if (!names.empty())
              w.create_group(g);
            for (const auto &n : names)
              w.create_group(g + "/" + n);
          };
          group("/planes", planes);
          for (const auto &n : planes)
            {
              dataset("/planes/" + n + "/force", {N, 3});
              dataset("/planes/" + n + "/penetration", {N});
            }
          group("/vertices", vertices);
          for (const auto &n : vertices)
            dataset("/vertices/" + n + "/displacement", {N, 3});
          group("/probes", probes);
          for (const auto &n : probes)
            {
              dataset("/probes/" + n + "/force", {N, 3});
              dataset("/probes/" + n + "/displacement", {N, 3});
            }
          group("/fixed", fixed);
          for (const auto &n : fixed)
            dataset("/fixed/" + n + "/reaction", {N, 3});
          if (scene.outputs.surface)
            {
              const hsize_t nt = r.surface.triangles.size();
              w.create_group("/surface");
              w.write("/surface/node_tags", {nv}, r.surface.node_tags.data());
              w.write("/surface/coordinates", {nv, 3}, flatten(r.surface.coordinates).data());
              std::vector<long long> tri;
              for (const auto &t : r.surface.triangles)
                tri.insert(tri.end(), t.begin(), t.end());
              w.write("/surface/triangles", {nt, 3}, tri.data());
              dataset("/surface/displacement", {N, nv, 3});
            }
        }

      if (scene.outputs.csv)
        {
          series = open_csv(base + "_series.csv");
          std::string header = "time_s,kinetic_energy_J,strain_energy_J";
          const auto  vec3   = [&](const std::string &prefix, const std::string &unit) {
            for (const char *d : {"x", "y", "z"})
              header += "," + prefix + d + "_" + unit;
          };
          for (const auto &n : vertices)
            vec3(n + "_u", "m");
          for (const auto &n : probes)
            {
              vec3(n + "_u", "m");
              vec3(n + "_F", "N");
            }
          for (const auto &n : fixed)
            vec3(n + "_R", "N");
          if (contact)
            header += ",contact_energy_J,gravity_energy_J";
          for (const auto &n : planes)
            {
              vec3(n + "_F", "N");
              header += "," + n + "_penetration_m";
            }
          check(std::fprintf(series, "%s\n", header.c_str()) >= 0, base + "_series.csv");
          if (scene.outputs.surface)
            {
              surface = open_csv(base + "_surface.csv");
              check(std::fprintf(surface, "time_s,node_tag,ux_m,uy_m,uz_m\n") >= 0,
                    base + "_surface.csv");
            }
        }
      started = true;
    }

    void
    append(const RunResult &r)
    {
      if (!started)
        start(r);
      const hsize_t n = r.time.size();
      if (written + n > N)
        throw std::logic_error("ResultWriter: more samples than announced");
      if (n == 0)
        return;
      if (h5)
        {
          auto &w = *h5;
          w.write_rows("/time", written, n, r.time.data());
          w.write_rows("/energy/kinetic", written, n, r.kinetic_energy.data());
          w.write_rows("/energy/strain", written, n, r.strain_energy.data());
          if (!r.contact_energy.empty())
            {
              w.write_rows("/energy/contact", written, n, r.contact_energy.data());
              w.write_rows("/energy/gravity", written, n, r.gravity_energy.data());
            }
          for (const auto &p : planes)
            {
              w.write_rows("/planes/" + p + "/force", written, n, flatten(r.plane_force.at(p)).data());
              w.write_rows("/planes/" + p + "/penetration", written, n,
                           r.plane_penetration.at(p).data());
            }
          for (const auto &v : vertices)
            w.write_rows("/vertices/" + v + "/displacement", written, n,
                         flatten(r.vertex_displacement.at(v)).data());
          for (const auto &p : probes)
            {
              w.write_rows("/probes/" + p + "/force", written, n, flatten(r.probe_force.at(p)).data());
              w.write_rows("/probes/" + p + "/displacement", written, n,
                           flatten(r.probe_displacement.at(p)).data());
            }
          for (const auto &f : fixed)
            w.write_rows("/fixed/" + f + "/reaction", written, n,
                         flatten(r.fixed_reaction.at(f)).data());
          if (scene.outputs.surface)
            for (hsize_t k = 0; k < n; ++k)
              w.write_rows("/surface/displacement", written + k, 1, r.surface_displacement[k].data());
        }
      if (series)
        {
          const std::string path = base + "_series.csv";
          bool              ok   = true;
          const auto num = [&](const double x) { ok = ok && std::fprintf(series, ",%.17g", x) >= 0; };
          const auto vec = [&](const Vec3 &x) {
            for (const double c : x)
              num(c);
          };
          for (hsize_t k = 0; k < n && ok; ++k)
            {
              ok = std::fprintf(series, "%.17g", r.time[k]) >= 0;
              num(r.kinetic_energy[k]);
              num(r.strain_energy[k]);
              for (const auto &v : vertices)
                vec(r.vertex_displacement.at(v)[k]);
              for (const auto &p : probes)
                {
                  vec(r.probe_displacement.at(p)[k]);
                  vec(r.probe_force.at(p)[k]);
                }
              for (const auto &f : fixed)
                vec(r.fixed_reaction.at(f)[k]);
              if (!r.contact_energy.empty())
                {
                  num(r.contact_energy[k]);
                  num(r.gravity_energy[k]);
                }
              for (const auto &p : planes)
                {
                  vec(r.plane_force.at(p)[k]);
                  num(r.plane_penetration.at(p)[k]);
                }
              ok = ok && std::fputc('\n', series) != EOF;
            }
          check(ok, path);
          if (surface)
            {
              const auto &tags = r.surface.node_tags;
              for (hsize_t k = 0; k < n && ok; ++k)
                for (size_t i = 0; i < tags.size() && ok; ++i)
                  {
                    const double *u = &r.surface_displacement[k][3 * i];
                    ok = std::fprintf(surface, "%.17g,%.17g,%.17g,%.17g,%.17g\n", r.time[k],
                                      static_cast<double>(tags[i]), u[0], u[1], u[2]) >= 0;
                  }
              check(ok, base + "_surface.csv");
            }
        }
      written += n;
    }

    void
    finish(const RunResult &r)
    {
      if (!started)
        start(r);
      if (written != N)
        throw std::logic_error("ResultWriter: " + std::to_string(written) + " samples written, " +
                               std::to_string(N) + " announced");
      if (h5)
        {
          for (const auto &p : planes)
            {
              // Which contact made the force: the face penalty, or vertex contact (linear).
              const auto k = r.plane_vertex_stiffness.find(p);
              if (k == r.plane_vertex_stiffness.end())
                h5->attribute("/planes/" + p, "penalty_Pa_m", r.plane_penalty.at(p));
              else
                h5->attribute("/planes/" + p, "vertex_stiffness_N_m", k->second);
            }
          for (const auto &v : vertices)
            h5->attribute("/vertices/" + v, "node_tag", r.vertex_node_tag.at(v));
          for (const auto &p : probes)
            h5->attribute("/probes/" + p, "node_tag", r.vertex_node_tag.at(p));
          h5->commit();
          h5.reset();
        }
      for (auto [file, name] : {std::pair{&series, "_series.csv"}, std::pair{&surface, "_surface.csv"}})
        if (*file)
          {
            const std::string path    = base + name;
            const bool        flushed = std::fflush(*file) == 0;
            const bool        closed  = std::fclose(*file) == 0;
            *file                     = nullptr;
            if (!flushed || !closed)
              {
                std::remove((path + ".part").c_str());
                throw IoError("cannot write '" + path + "': " + std::strerror(errno));
              }
            commit_part_file(path + ".part", path);
          }
    }
  };

  ResultWriter::ResultWriter(const Scene &scene, const unsigned n_dofs, const unsigned n)
  {
    if (scene.outputs.directory.empty())
      throw std::logic_error("ResultWriter: the scene has no output directory");
    std::error_code ec;
    fs::create_directories(scene.outputs.directory, ec);
    if (ec)
      throw InputError("cannot create output directory '" + scene.outputs.directory +
                       "': " + ec.message());
    impl_ = std::make_unique<Impl>(scene, n_dofs, n);
  }

  ResultWriter::~ResultWriter() = default;

  void
  ResultWriter::append(const RunResult &batch)
  {
    impl_->append(batch);
  }

  void
  ResultWriter::finish(const RunResult &last)
  {
    impl_->finish(last);
  }

  void
  ElasticDynamics::Impl::write_outputs(const RunResult &r) const
  {
    if (scene.outputs.directory.empty())
      return;
    ResultWriter w(scene, dof_handler.n_dofs(), static_cast<unsigned>(r.time.size()));
    w.append(r);
    w.finish(r);
  }

  void
  ElasticDynamics::Impl::write_vtu(const Vector<double> &u,
                                   const unsigned step,
                                   const double t,
                                   std::vector<std::pair<double, std::string>> &records) const
  {
    const fs::path dir = fs::path(scene.outputs.directory) / "vtu";
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec)
      throw InputError("cannot create '" + dir.string() + "': " + ec.message());
    DataOut<3> data_out;
    data_out.attach_dof_handler(dof_handler);
    std::vector<DataComponentInterpretation::DataComponentInterpretation> kind(
      3, DataComponentInterpretation::component_is_part_of_vector);
    data_out.add_data_vector(u, std::vector<std::string>(3, "displacement_m"),
                             DataOut<3>::type_dof_data, kind);
    // n_subdivisions = degree: quadratic tetrahedra for P2 (VTK cell type 24).
    data_out.build_patches(mapping, scene.fe_degree);
    char number[16];
    std::snprintf(number, sizeof number, "_%06u.vtu", step);
    const std::string  name = scene.name + number;
    std::ostringstream vtu;
    data_out.write_vtu(vtu);
    write_text_file((dir / name).string(), vtu.str());
    records.emplace_back(t, std::string("vtu/") + name);
    std::ostringstream pvd;
    DataOutBase::write_pvd_record(pvd, records);
    write_text_file((fs::path(scene.outputs.directory) / (scene.name + ".pvd")).string(), pvd.str());
  }
} // namespace irdm::fem
