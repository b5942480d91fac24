// ElasticDynamics outputs: HDF5 (layout in docs/fem-output.md), CSV, VTU time series.
#include <deal.II/base/data_out_base.h>
#include <deal.II/numerics/data_out.h>

#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include "elastodynamics_impl.h"

#include <filesystem>
#include <algorithm>
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

    void
    add_vec3_columns(const std::string &prefix,
                     const std::string &unit,
                     const std::vector<Vec3> &series,
                     std::vector<std::string> &header,
                     std::vector<std::vector<double>> &columns)
    {
      for (unsigned d = 0; d < 3; ++d)
        {
          header.push_back(prefix + "xyz"[d] + "_" + unit);
          std::vector<double> col;
          for (const auto &v : series)
            col.push_back(v[d]);
          columns.push_back(col);
        }
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
  ElasticDynamics::Impl::write_outputs(const RunResult &r) const
  {
    if (scene.outputs.directory.empty())
      return;
    std::error_code ec;
    fs::create_directories(scene.outputs.directory, ec);
    if (ec)
      throw InputError("cannot create output directory '" + scene.outputs.directory +
                       "': " + ec.message());
    const std::string base = (fs::path(scene.outputs.directory) / scene.name).string();
    const hsize_t     N    = r.time.size();

    if (scene.outputs.hdf5)
      {
        h5::Writer w(base + ".h5");
        w.attribute("/", "format", std::string("irdm-fem-result/1"));
        w.attribute("/", "units", std::string("SI: m, s, N, kg, Pa, J"));
        w.attribute("/", "program_version", std::string(IRDM_VERSION));
        w.attribute("/", "scene_json", scene.json_text);
        w.attribute("/", "mesh_file", scene.mesh_file);
        w.attribute("/", "mesh_fnv1a64", file_hash(scene.mesh_file));
        w.attribute("/", "fe_degree", static_cast<long long>(scene.fe_degree));
        w.attribute("/", "n_dofs", static_cast<long long>(dof_handler.n_dofs()));
        w.attribute("/", "youngs_modulus_Pa", scene.youngs_modulus);
        w.attribute("/", "poisson_ratio", scene.poisson_ratio);
        w.attribute("/", "density_kg_m3", scene.density);
        w.attribute("/", "rayleigh_alpha_1_s", scene.rayleigh_alpha);
        w.attribute("/", "rayleigh_beta_s", scene.rayleigh_beta);
        w.attribute("/", "integrator", std::string(integrator_name(scene)));
        w.attribute("/", "rho_inf", scene.rho_inf);
        w.attribute("/", "time_step_s", scene.time_step);
        w.write("/time", {N}, r.time.data());
        w.create_group("/energy");
        w.write("/energy/kinetic", {N}, r.kinetic_energy.data());
        w.write("/energy/strain", {N}, r.strain_energy.data());
        w.attribute("/", "kinematics", std::string(scene.kinematics == Kinematics::nonlinear
                                                     ? "nonlinear (Total Lagrangian neo-Hookean)"
                                                     : "linear"));
        if (!r.contact_energy.empty())
          {
            w.write("/energy/contact", {N}, r.contact_energy.data());
            w.write("/energy/gravity", {N}, r.gravity_energy.data());
          }
        if (!r.plane_force.empty())
          w.create_group("/planes");
        for (const auto &[name, series] : r.plane_force)
          {
            w.create_group("/planes/" + name);
            w.write("/planes/" + name + "/force", {N, 3}, flatten(series).data());
            w.write("/planes/" + name + "/penetration", {N}, r.plane_penetration.at(name).data());
            w.attribute("/planes/" + name, "penalty_Pa_m", r.plane_penalty.at(name));
          }
        if (!r.vertex_displacement.empty())
          w.create_group("/vertices");
        for (const auto &[name, series] : r.vertex_displacement)
          {
            w.create_group("/vertices/" + name);
            w.write("/vertices/" + name + "/displacement", {N, 3}, flatten(series).data());
            w.attribute("/vertices/" + name, "node_tag", r.vertex_node_tag.at(name));
          }
        if (!r.probe_force.empty())
          w.create_group("/probes");
        for (const auto &[name, series] : r.probe_force)
          {
            w.create_group("/probes/" + name);
            w.write("/probes/" + name + "/force", {N, 3}, flatten(series).data());
            w.write("/probes/" + name + "/displacement", {N, 3},
                    flatten(r.probe_displacement.at(name)).data());
            w.attribute("/probes/" + name, "node_tag", r.vertex_node_tag.at(name));
          }
        if (!r.fixed_reaction.empty())
          w.create_group("/fixed");
        for (const auto &[name, series] : r.fixed_reaction)
          {
            w.create_group("/fixed/" + name);
            w.write("/fixed/" + name + "/reaction", {N, 3}, flatten(series).data());
          }
        if (scene.outputs.surface)
          {
            const hsize_t nv = r.surface.node_tags.size(), nt = r.surface.triangles.size();
            w.create_group("/surface");
            w.write("/surface/node_tags", {nv}, r.surface.node_tags.data());
            w.write("/surface/coordinates", {nv, 3}, flatten(r.surface.coordinates).data());
            std::vector<long long> tri;
            for (const auto &t : r.surface.triangles)
              tri.insert(tri.end(), t.begin(), t.end());
            w.write("/surface/triangles", {nt, 3}, tri.data());
            std::vector<double> all;
            all.reserve(N * nv * 3);
            for (const auto &s : r.surface_displacement)
              all.insert(all.end(), s.begin(), s.end());
            w.write("/surface/displacement", {N, nv, 3}, all.data());
          }
        w.commit();
      }

    if (scene.outputs.csv)
      {
        std::vector<std::string>         header{"time_s", "kinetic_energy_J", "strain_energy_J"};
        std::vector<std::vector<double>> columns{r.time, r.kinetic_energy, r.strain_energy};
        std::vector<std::string> vertex_order, probe_order, plane_order;
        for (const auto &v : scene.outputs.vertices)
          vertex_order.push_back(v.name);
        for (const auto &p : scene.prescribed)
          probe_order.push_back(p.name);
        for (const auto &p : scene.probes)
          probe_order.push_back(p.name);
        for (const auto &p : scene.planes)
          plane_order.push_back(p.name);
        for (const auto &name : in_scene_order(r.vertex_displacement, vertex_order))
          add_vec3_columns(name + "_u", "m", r.vertex_displacement.at(name), header, columns);
        for (const auto &name : in_scene_order(r.probe_force, probe_order))
          {
            add_vec3_columns(name + "_u", "m", r.probe_displacement.at(name), header, columns);
            add_vec3_columns(name + "_F", "N", r.probe_force.at(name), header, columns);
          }
        for (const auto &name : in_scene_order(r.fixed_reaction, scene.fixed_surfaces))
          add_vec3_columns(name + "_R", "N", r.fixed_reaction.at(name), header, columns);
        if (!r.contact_energy.empty())
          {
            header.insert(header.end(), {"contact_energy_J", "gravity_energy_J"});
            columns.push_back(r.contact_energy);
            columns.push_back(r.gravity_energy);
          }
        for (const auto &name : in_scene_order(r.plane_force, plane_order))
          {
            add_vec3_columns(name + "_F", "N", r.plane_force.at(name), header, columns);
            header.push_back(name + "_penetration_m");
            columns.push_back(r.plane_penetration.at(name));
          }
        write_csv(base + "_series.csv", header, columns);
        if (scene.outputs.surface)
          {
            std::vector<std::vector<double>> cols(5);
            for (std::size_t k = 0; k < N; ++k)
              for (std::size_t i = 0; i < r.surface.node_tags.size(); ++i)
                {
                  cols[0].push_back(r.time[k]);
                  cols[1].push_back(static_cast<double>(r.surface.node_tags[i]));
                  for (unsigned d = 0; d < 3; ++d)
                    cols[2 + d].push_back(r.surface_displacement[k][3 * i + d]);
                }
            write_csv(base + "_surface.csv", {"time_s", "node_tag", "ux_m", "uy_m", "uz_m"}, cols);
          }
      }
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
