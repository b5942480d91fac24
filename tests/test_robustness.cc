// Robustness of everything that reads a file or writes one, without deal.II so that CI runs it
// under AddressSanitizer and UndefinedBehaviorSanitizer (scripts/sanitize.sh):
//  - loaders against hostile files: a seed corpus the tests make (a small impulse-response
//    model, its compressed form, a gmsh mesh), every dataset and attribute mutated in turn in
//    every way that broke a loader before, then random mutations for a fixed time. A loaded
//    mutant is then run by the runtime: only a model or an InputError may come out, never a
//    crash, a sanitizer report or another exception;
//  - writers against a failing disk (RLIMIT_FSIZE: writes past the limit fail with EFBIG, as on
//    a full disk): an IoError, and nothing under the final name;
//  - output locks and output-path checks.
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/plane_interaction.h>
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <reference_fem/mesh.h>

#include <gtest/gtest.h>

#include "scratch.h"

#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

namespace
{
  namespace fs = std::filesystem;
  using namespace irdm;

  // Each test writes in its own folder (irdm_test::tmp, scratch.h): ctest runs tests in parallel,
  // and two writers to one file would (rightly) be refused by its lock.
  using irdm_test::tmp;

  // ---- seed corpus ----

  // A small but complete impulse-response model: 4 output vertices (a tetrahedron's surface),
  // 3 of them inputs, T = 8, a diagonally dominant feed-through so that contact solves.
  void
  write_seed_model(const std::string &path)
  {
    fs::remove(path);
    const unsigned nv = 4, ni = 3, T = 8, nout = 3 * nv, nin = 3 * ni, modes = 2;
    h5::Writer     w(path);
    w.attribute("/", "format", std::string("irdm-impulse-response"));
    w.attribute("/", "format_version", 2LL);
    w.attribute("/", "time_step_s", 0.002);
    w.attribute("/", "length", static_cast<long long>(T));
    w.attribute("/", "integrator", std::string("newmark_average_acceleration"));
    w.attribute("/", "mesh_hash", std::string("0123456789abcdef"));
    w.attribute("/", "storage", std::string("double"));
    // A free body (version 2), so that the mutations reach its mass properties too.
    w.attribute("/", "body", std::string("free"));
    w.create_group("/rigid_body");
    const double              mass = 0.5;
    const std::vector<double> center = {0.01, 0.02, 0.03},
                              inertia = {2e-4, 0, 0, 0, 3e-4, 0, 0, 0, 4e-4};
    w.write("/rigid_body/mass_kg", {1}, &mass);
    w.write("/rigid_body/center_of_mass_m", {3}, center.data());
    w.write("/rigid_body/inertia_kg_m2", {3, 3}, inertia.data());
    const std::vector<long long> out_tags = {10, 11, 12, 13}, in_tags = {10, 11, 12};
    const std::vector<double>    xyz      = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
    w.create_group("/outputs");
    w.write("/outputs/node_tags", {nv}, out_tags.data());
    w.write("/outputs/coordinates", {nv, 3}, xyz.data());
    w.create_group("/inputs");
    w.write("/inputs/node_tags", {ni}, in_tags.data());
    w.write("/inputs/coordinates", {ni, 3}, xyz.data());
    const std::vector<long long> io = {0, 1, 2};
    w.write("/inputs/output_index", {ni}, io.data());
    w.create_group("/surface");
    const std::vector<long long> tri = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2}, tri_s = {0, 0, 0, 0};
    w.write("/surface/triangles", {4, 3}, tri.data());
    w.write("/surface/triangle_surface", {4}, tri_s.data());
    w.attribute("/surface", "surface_names", std::string("skin"));
    std::vector<double> H(static_cast<size_t>(nin) * T * nout);
    for (unsigned a = 0; a < nin; ++a)
      for (unsigned s = 0; s < T; ++s)
        for (unsigned b = 0; b < nout; ++b)
          H[(static_cast<size_t>(a) * T + s) * nout + b] =
            std::exp(-static_cast<double>(s) / 3.0) * ((a == b ? 1e-3 : 0) + 1e-5 * std::cos(a + b + s));
    w.create_group("/impulse_response");
    w.write("/impulse_response/H", {nin, T, nout}, H.data());
    w.create_group("/modes");
    const std::vector<double> hz = {1, 2}, zeta = {0.01, 0.02};
    std::vector<double>       shapes(nout * modes), step(modes * 15, 0);
    for (unsigned i = 0; i < shapes.size(); ++i)
      shapes[i] = 0.1 * std::sin(1.0 + i);
    for (unsigned m = 0; m < modes; ++m)
      for (unsigned r = 0; r < 3; ++r)
        step[15 * m + 5 * r + r] = 0.9; // A = 0.9 I, b = 0
    w.write("/modes/frequency_Hz", {modes}, hz.data());
    w.write("/modes/damping_ratio", {modes}, zeta.data());
    w.write("/modes/shapes", {nout, modes}, shapes.data());
    w.write("/modes/step", {modes, 3, 5}, step.data());
    w.create_group("/progress");
    const std::vector<long long> done = {1, 1};
    w.write("/progress/chunk_done", {2}, done.data());
    w.commit();
  }

  void
  write_seed_compressed(const std::string &model_path, const std::string &path)
  {
    fs::remove(path);
    CompressionOptions o;
    o.theta   = 0.5;
    o.blend   = 2;
    o.threads = 1;
    save_representative_model(compress(load_model(model_path), o), model_path, path);
  }

  // A small virtual-DOF model: the 12 icosahedron directions (20 dome triangles), the same
  // 4-vertex surface (one vertex fixed), T = 6, compliant virtual DOFs.
  void
  write_seed_virtual_dofs(const std::string &path)
  {
    fs::remove(path);
    const double              phi = (1 + std::sqrt(5.0)) / 2;
    std::vector<std::array<double, 3>> v;
    for (const double a : {-1.0, 1.0})
      for (const double b : {-phi, phi})
        {
          v.push_back({0, a, b});
          v.push_back({a, b, 0});
          v.push_back({b, 0, a});
        }
    std::vector<double>    dirs;
    for (const auto &x : v)
      {
        const double n = std::hypot(x[0], x[1], x[2]);
        dirs.insert(dirs.end(), {x[0] / n, x[1] / n, x[2] / n});
      }
    const auto dist = [&](const unsigned i, const unsigned j) {
      return std::hypot(v[i][0] - v[j][0], v[i][1] - v[j][1], v[i][2] - v[j][2]);
    };
    std::vector<long long> dome;
    for (unsigned i = 0; i < 12; ++i)
      for (unsigned j = i + 1; j < 12; ++j)
        for (unsigned k = j + 1; k < 12; ++k)
          if (std::abs(dist(i, j) - 2) < 1e-9 && std::abs(dist(j, k) - 2) < 1e-9 &&
              std::abs(dist(i, k) - 2) < 1e-9)
            dome.insert(dome.end(), {i, j, k});
    const hsize_t K = 12, T = 6, n = 4;
    std::vector<float>  surface(K * T * 3 * n);
    std::vector<double> dof(K * T * K, 0), rest(K, 0.02), first(K, 0.05), force(K, 0.5);
    for (hsize_t k = 0; k < K; ++k)
      for (hsize_t t = 0; t < T; ++t)
        {
          for (hsize_t j = 0; j < 3 * n; ++j)
            surface[(k * T + t) * 3 * n + j] = static_cast<float>(1e-3 * std::exp(-0.5 * t) * std::cos(k + j));
          dof[(k * T + t) * K + k] = 2e-3 * std::exp(-0.5 * t);
        }
    h5::Writer w(path);
    w.attribute("/", "format", std::string("irdm-virtual-dof-model"));
    w.attribute("/", "format_version", 2LL);
    w.attribute("/", "time_step_s", 0.002);
    w.attribute("/", "mesh_hash", std::string("0123456789abcdef"));
    w.attribute("/", "integrator", std::string("newmark_average_acceleration"));
    w.create_group("/virtual_dofs");
    w.write("/virtual_dofs/directions", {K, 3}, dirs.data());
    w.write("/virtual_dofs/dome_triangles", {dome.size() / 3, 3}, dome.data());
    w.write("/virtual_dofs/first_contact", {K}, first.data());
    w.write("/virtual_dofs/rest_position", {K}, rest.data());
    w.write("/virtual_dofs/impulse_force", {K}, force.data());
    w.write("/virtual_dofs/surface_response", {K, T, 3 * n}, surface.data());
    w.write("/virtual_dofs/dof_response", {K, T, K}, dof.data());
    const std::vector<long long> tags = {10, 11, 12, 13}, fixed = {0, 0, 0, 1};
    const std::vector<double>    xyz  = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
    w.create_group("/outputs");
    w.write("/outputs/node_tags", {n}, tags.data());
    w.write("/outputs/coordinates", {n, 3}, xyz.data());
    w.write("/outputs/fixed", {n}, fixed.data());
    w.create_group("/surface");
    const std::vector<long long> tri = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
    w.write("/surface/triangles", {4, 3}, tri.data());
    w.commit();
  }

  // ---- generic in-place mutation of an HDF5 file ----

  struct Item
  {
    std::string object, attribute; // attribute empty: a dataset
  };

  herr_t
  collect(hid_t, const char *name, const H5O_info_t *info, void *data)
  {
    auto &objects = *static_cast<std::vector<std::pair<std::string, bool>> *>(data);
    objects.emplace_back(std::string("/") + (std::string(name) == "." ? "" : name),
                         info->type == H5O_TYPE_DATASET);
    return 0;
  }

  std::vector<Item>
  items_of(const std::string &path)
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    std::vector<std::pair<std::string, bool>> objects;
    H5Ovisit2(f, H5_INDEX_NAME, H5_ITER_INC, collect, &objects, H5O_INFO_BASIC);
    std::vector<Item> items;
    for (const auto &[name, is_dataset] : objects)
      {
        if (is_dataset)
          items.push_back({name, ""});
        const hid_t obj = H5Oopen(f, name.c_str(), H5P_DEFAULT);
        H5O_info_t info;
        H5Oget_info2(obj, &info, H5O_INFO_NUM_ATTRS);
        for (hsize_t i = 0; i < info.num_attrs; ++i)
          {
            char buf[256];
            H5Aget_name_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, buf, sizeof buf,
                               H5P_DEFAULT);
            items.push_back({name, buf});
          }
        H5Oclose(obj);
      }
    H5Fclose(f);
    return items;
  }

  // The values that broke loaders before, and their neighbours.
  const std::vector<double> nasty = {std::numeric_limits<double>::quiet_NaN(),
                                     std::numeric_limits<double>::infinity(),
                                     -1,
                                     0,
                                     0.5,
                                     1e18,
                                     -1e18,
                                     4294967296.0,
                                     65536,
                                     1e300};

  // Mutations of a dataset: a value changed, a row dropped, flattened, made text, deleted.
  enum class DataMutation
  {
    value,
    drop_row,
    flatten,
    text,
    remove
  };

  void
  mutate_dataset(const std::string &path, const std::string &name, const DataMutation how,
                 const double value, const size_t position)
  {
    const hid_t f   = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t set = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
    const hid_t space = H5Dget_space(set), type = H5Dget_type(set);
    const int   rank  = H5Sget_simple_extent_ndims(space);
    std::vector<hsize_t> dims(std::max(rank, 1), 1);
    if (rank > 0)
      H5Sget_simple_extent_dims(space, dims.data(), nullptr);
    const bool is_int = H5Tget_class(type) == H5T_INTEGER;
    size_t     n      = 1;
    for (const auto d : dims)
      n *= d;
    std::vector<double> v(n);
    H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Tclose(type);
    H5Sclose(space);
    H5Dclose(set);
    H5Ldelete(f, name.c_str(), H5P_DEFAULT);
    if (how != DataMutation::remove)
      {
        if (how == DataMutation::value && n > 0)
          v[position % n] = value;
        if (how == DataMutation::drop_row && dims[0] > 0)
          {
            v.resize(n / dims[0] * (dims[0] - 1));
            dims[0] -= 1;
          }
        if (how == DataMutation::flatten)
          dims = {n};
        hid_t file_type = is_int ? H5T_STD_I64LE : H5T_IEEE_F64LE;
        if (how == DataMutation::text)
          {
            file_type = H5Tcopy(H5T_C_S1);
            H5Tset_size(file_type, 8);
          }
        const hid_t s2 = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
        const hid_t d2 = H5Dcreate2(f, name.c_str(), file_type, s2, H5P_DEFAULT, H5P_DEFAULT,
                                    H5P_DEFAULT);
        if (how == DataMutation::text)
          {
            std::vector<char> text(8 * v.size(), 'x');
            H5Dwrite(d2, file_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data());
            H5Tclose(file_type);
          }
        else if (is_int)
          {
            // Integers take the value's saturated whole part (NaN -> 0): what a hostile writer
            // could store.
            std::vector<long long> iv(v.size());
            for (size_t i = 0; i < v.size(); ++i)
              iv[i] = std::isfinite(v[i]) && std::abs(v[i]) < 9e18 ? static_cast<long long>(v[i])
                      : std::isnan(v[i])                            ? 0
                      : v[i] > 0 ? std::numeric_limits<long long>::max()
                                 : std::numeric_limits<long long>::min();
            H5Dwrite(d2, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, iv.data());
          }
        else
          H5Dwrite(d2, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
        H5Dclose(d2);
        H5Sclose(s2);
      }
    H5Fclose(f);
  }

  enum class AttributeMutation
  {
    value,
    array,
    text,
    remove
  };

  void
  mutate_attribute(const std::string &path, const Item &item, const AttributeMutation how,
                   const double value)
  {
    const hid_t f   = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t obj = H5Oopen(f, item.object.c_str(), H5P_DEFAULT);
    H5Adelete(obj, item.attribute.c_str());
    if (how != AttributeMutation::remove)
      {
        const hsize_t two   = 2;
        const hid_t   space = how == AttributeMutation::array ? H5Screate_simple(1, &two, nullptr)
                                                              : H5Screate(H5S_SCALAR);
        hid_t type = H5Tcopy(H5T_NATIVE_DOUBLE);
        if (how == AttributeMutation::text)
          {
            H5Tclose(type);
            type = H5Tcopy(H5T_C_S1);
            H5Tset_size(type, 5);
          }
        const hid_t attr = H5Acreate2(obj, item.attribute.c_str(), type, space, H5P_DEFAULT,
                                      H5P_DEFAULT);
        const double values[2] = {value, value};
        H5Awrite(attr, type, how == AttributeMutation::text ? static_cast<const void *>("12abc")
                                                            : static_cast<const void *>(values));
        H5Aclose(attr);
        H5Tclose(type);
        H5Sclose(space);
      }
    H5Oclose(obj);
    H5Fclose(f);
  }

  // ---- what each loader must survive ----

  // Loads the file and, if it loads, runs the runtime on it: true if it loaded. Only an
  // InputError may escape the loader; anything else fails the test.
  using Loader = std::function<bool(const std::string &)>;

  // Loads with load_fn and, if that succeeds, drives Interaction for 3 T steps with a probe
  // pressing triangle 0 (lifted if it cannot touch there), then updates the surface.
  template <typename Interaction, typename LoadFn>
  bool
  load_and_run(const std::string &path, const LoadFn &load_fn)
  {
    try
      {
        const auto  m = load_fn(path);
        Interaction run(m);
        ProbeTarget p;
        p.triangle = 0;
        p.weights  = {1.0 / 3, 1.0 / 3, 1.0 / 3};
        p.present  = run.can_touch(0);
        for (int s = 0; s < 3 * static_cast<int>(m.length); ++s)
          {
            p.displacement = {0, 0, -1e-4 * s};
            run.step(&p, 1);
          }
        std::vector<double> u(m.n_outputs);
        run.surface_displacement(u.data());
        return true;
      }
    catch (const InputError &)
      {
        return false;
      }
  }

  // The uncompressed model runs twice: by direct convolution, and (if the file holds a modal
  // realization) as the modal model made from it.
  bool
  load_and_run_model(const std::string &path)
  {
    const bool direct =
      load_and_run<PointInteraction>(path, [](const std::string &f) { return load_model(f); });
    if (direct)
      {
        const ImpulseResponseModel m = load_model(path);
        if (m.modes.n_modes > 0)
          load_and_run<ModalInteraction>(path, [&](const std::string &) {
            ModalModelOptions o;
            o.surface_modes = m.modes.n_modes;
            return make_modal_model(m, o);
          });
      }
    return direct;
  }

  bool
  load_and_run_compressed(const std::string &path)
  {
    return load_and_run<RepresentativeInteraction>(
      path, [](const std::string &f) { return load_representative_model(f); });
  }

  // A wall along a direction between the dome's, pressing in and out, with both mappings.
  bool
  load_and_run_virtual_dofs(const std::string &path)
  {
    try
      {
        const VirtualDofModel m = load_virtual_dof_model(path);
        for (const auto mapping : {OrientationMapping::nearest, OrientationMapping::interpolated})
          {
            PlaneInteraction             wall(m, mapping);
            const std::array<double, 3> d = {0.48, 0.6, -0.64};
            for (int s = 0; s < 3 * static_cast<int>(m.length); ++s)
              wall.step(d, 0.01 * std::sin(0.3 * s));
            wall.update_surface();
          }
        return true;
      }
    catch (const InputError &)
      {
        return false;
      }
  }

  struct Tally
  {
    int mutants = 0, loaded = 0, refused = 0;
  };

  // Every item mutated in every structured way, one mutant at a time.
  Tally
  structured_mutations(const std::string &seed, const Loader &load)
  {
    Tally      tally;
    const auto mutant = tmp("mutant.h5");
    const auto count  = [&](const bool loaded) {
      ++tally.mutants;
      (loaded ? tally.loaded : tally.refused) += 1;
    };
    for (const auto &item : items_of(seed))
      {
        SCOPED_TRACE(item.object + (item.attribute.empty() ? "" : " @" + item.attribute));
        if (item.attribute.empty())
          {
            for (const auto how : {DataMutation::drop_row, DataMutation::flatten,
                                   DataMutation::text, DataMutation::remove})
              {
                fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
                mutate_dataset(mutant, item.object, how, 0, 0);
                count(load(mutant));
              }
            for (const double v : nasty)
              for (const size_t position : {size_t(0), size_t(7), size_t(1000003)})
                {
                  fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
                  mutate_dataset(mutant, item.object, DataMutation::value, v, position);
                  count(load(mutant));
                }
          }
        else
          {
            for (const auto how :
                 {AttributeMutation::array, AttributeMutation::text, AttributeMutation::remove})
              {
                fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
                mutate_attribute(mutant, item, how, 3);
                count(load(mutant));
              }
            for (const double v : nasty)
              {
                fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
                mutate_attribute(mutant, item, AttributeMutation::value, v);
                count(load(mutant));
              }
          }
      }
    return tally;
  }

  // Random mutants (1 to 3 changes each) until the time is up; the seed is fixed so that a
  // failure repeats.
  Tally
  random_mutations(const std::string &seed, const Loader &load, const double seconds)
  {
    Tally                     tally;
    std::mt19937              rng(20261122);
    const auto                items  = items_of(seed);
    const auto                mutant = tmp("random_mutant.h5");
    const auto                t0     = std::chrono::steady_clock::now();
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds)
      {
        fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
        const int changes = 1 + static_cast<int>(rng() % 3);
        for (int c = 0; c < changes; ++c)
          {
            const Item  &item  = items[rng() % items.size()];
            const double value = rng() % 2 ? nasty[rng() % nasty.size()]
                                           : std::ldexp(static_cast<double>(rng() % 2001) - 1000,
                                                        static_cast<int>(rng() % 80) - 40);
            if (!fs::exists(mutant))
              break;
            if (item.attribute.empty())
              {
                const auto h5 = H5Fopen(mutant.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
                const bool present = H5Lexists(h5, item.object.c_str(), H5P_DEFAULT) > 0;
                H5Fclose(h5);
                if (present)
                  mutate_dataset(mutant, item.object,
                                 rng() % 8 ? DataMutation::value
                                           : static_cast<DataMutation>(1 + rng() % 4),
                                 value, rng());
              }
            else
              {
                const auto h5  = H5Fopen(mutant.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
                const bool has = H5Aexists_by_name(h5, item.object.c_str(),
                                                   item.attribute.c_str(), H5P_DEFAULT) > 0;
                H5Fclose(h5);
                if (has)
                  mutate_attribute(mutant, item,
                                   rng() % 4 ? AttributeMutation::value
                                             : static_cast<AttributeMutation>(1 + rng() % 3),
                                   value);
              }
          }
        const bool loaded = load(mutant);
        ++tally.mutants;
        (loaded ? tally.loaded : tally.refused) += 1;
      }
    return tally;
  }

  double
  fuzz_seconds()
  {
    const char *s = std::getenv("IRDM_FUZZ_SECONDS");
    return s ? std::atof(s) : 10.0;
  }

  // The two fuzz stages for one loader, with what they did printed for the log.
  void
  expect_structured_mutations_survive(const char *what, const std::string &seed, const Loader &load)
  {
    ASSERT_TRUE(load(seed)) << "the seed itself does not load";
    const Tally t = structured_mutations(seed, load);
    std::printf("%s: %d structured mutants, %d loaded and ran, %d refused\n", what, t.mutants,
                t.loaded, t.refused);
    EXPECT_GT(t.mutants, 300);
  }

  void
  expect_random_mutations_survive(const char *what, const std::string &seed, const Loader &load)
  {
    const Tally t = random_mutations(seed, load, fuzz_seconds());
    std::printf("%s: %d random mutants in %.0f s, %d loaded and ran, %d refused\n", what,
                t.mutants, fuzz_seconds(), t.loaded, t.refused);
    EXPECT_GT(t.mutants, 10);
  }
} // namespace

TEST(ModelLoaderFuzz, EveryStructuredMutationLoadsOrIsRefusedClearly)
{
  const auto seed = tmp("seed_model.h5");
  write_seed_model(seed);
  expect_structured_mutations_survive("model loader", seed, load_and_run_model);
}

TEST(ModelLoaderFuzz, RandomMutationsForAFixedTime)
{
  const auto seed = tmp("seed_model.h5");
  write_seed_model(seed);
  expect_random_mutations_survive("model loader", seed, load_and_run_model);
}

TEST(CompressedLoaderFuzz, EveryStructuredMutationLoadsOrIsRefusedClearly)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_compressed.h5");
  write_seed_model(model);
  write_seed_compressed(model, seed);
  expect_structured_mutations_survive("compressed loader", seed, load_and_run_compressed);
}

TEST(CompressedLoaderFuzz, RandomMutationsForAFixedTime)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_compressed.h5");
  write_seed_model(model);
  write_seed_compressed(model, seed);
  expect_random_mutations_survive("compressed loader", seed, load_and_run_compressed);
}

TEST(VirtualDofLoaderFuzz, EveryStructuredMutationLoadsOrIsRefusedClearly)
{
  const auto seed = tmp("seed_vdof.h5");
  write_seed_virtual_dofs(seed);
  expect_structured_mutations_survive("virtual-DOF loader", seed, load_and_run_virtual_dofs);
}

TEST(VirtualDofLoaderFuzz, RandomMutationsForAFixedTime)
{
  const auto seed = tmp("seed_vdof.h5");
  write_seed_virtual_dofs(seed);
  expect_random_mutations_survive("virtual-DOF loader", seed, load_and_run_virtual_dofs);
}

// The regressions named in the issue, each on its own.

TEST(ModelLoader, RefusesAnIncompleteModel)
{
  const auto path = tmp("incomplete.h5");
  write_seed_model(path);
  mutate_dataset(path, "/progress/chunk_done", DataMutation::value, 0, 1);
  try
    {
      load_model(path);
      FAIL() << "an incomplete model loaded";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("incomplete: 1 of 2 chunks"), std::string::npos)
        << e.what();
    }
}

TEST(ModelLoader, RefusesAnArrayWhereANumberBelongs)
{
  const auto path = tmp("array_attribute.h5");
  write_seed_model(path);
  mutate_attribute(path, {"/", "time_step_s"}, AttributeMutation::array, 0.002);
  EXPECT_THROW(load_model(path), InputError);
}

TEST(ModelLoader, RefusesNaNInModeShapesAndDuplicateOutputIndices)
{
  const auto path = tmp("nan_modes.h5");
  write_seed_model(path);
  mutate_dataset(path, "/modes/shapes", DataMutation::value,
                 std::numeric_limits<double>::quiet_NaN(), 5);
  EXPECT_THROW(load_model(path), InputError);
  write_seed_model(path);
  mutate_dataset(path, "/inputs/output_index", DataMutation::value, 0, 1); // {0, 0, 2}
  EXPECT_THROW(load_model(path), InputError);
}

TEST(CompressedLoader, ChecksSlotsOfAmplitudeZeroAndTheDelaySpan)
{
  const auto model = tmp("seed_model.h5"), path = tmp("slots.h5");
  write_seed_model(model);
  write_seed_compressed(model, path);
  const auto c = load_representative_model(path);
  // A slot of amplitude 0 (blend 2 leaves some) with an out-of-range representative.
  size_t zero = 0;
  while (zero < c.term_amplitude.size() && c.term_amplitude[zero] != 0)
    ++zero;
  ASSERT_LT(zero, c.term_amplitude.size()) << "the seed has no slot of amplitude 0";
  mutate_dataset(path, "/representatives/term_representative", DataMutation::value, 1e6, zero);
  EXPECT_THROW(load_representative_model(path), InputError);
  for (const double span : {-1.0, 1e9, 0.5})
    {
      write_seed_compressed(model, path);
      mutate_attribute(path, {"/", "delay_span_steps"}, AttributeMutation::value, span);
      EXPECT_THROW(load_representative_model(path), InputError) << span;
    }
}

// ---- meshes ----

namespace
{
  std::string
  read_text(const std::string &path)
  {
    std::ifstream      in(path);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  bool
  load_mesh(const std::string &text)
  {
    const auto path = tmp("mutant.msh");
    std::ofstream(path) << text;
    try
      {
        const fem::TetMesh m = fem::read_gmsh(path);
        return !m.tets.empty();
      }
    catch (const InputError &)
      {
        return false;
      }
  }
} // namespace

TEST(MeshLoader, RefusesHugeCountsAtOnce)
{
  const std::string seed = read_text(std::string(IRDM_MESH_DIR) + "/beam_2.msh");
  ASSERT_TRUE(load_mesh(seed));
  // The count after "$Nodes" (4.1: blocks, nodes, min, max) claims 1e18 nodes.
  std::string text = seed;
  const auto  at   = text.find("$Nodes\n") + 7;
  text.replace(at, text.find(' ', at) - at, "1000000000000000000");
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(load_mesh(text));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10);
}

TEST(MeshLoader, RefusesADuplicateTetrahedron)
{
  // A minimal 2.2 mesh with the same tetrahedron twice.
  const std::string mesh = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n"
                           "3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n2\n1 4 2 1 1 1 2 3 4\n"
                           "2 4 2 1 1 2 3 1 4\n$EndElements\n";
  const auto path = tmp("duplicate.msh");
  std::ofstream(path) << mesh;
  try
    {
      fem::read_gmsh(path);
      FAIL() << "a duplicate tetrahedron was accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("repeats element 1"), std::string::npos) << e.what();
    }
}

TEST(MeshLoaderFuzz, RandomLineAndTokenMutationsLoadOrAreRefused)
{
  const std::string seed = read_text(std::string(IRDM_MESH_DIR) + "/beam_2.msh");
  std::vector<std::string> lines;
  {
    std::istringstream in(seed);
    for (std::string l; std::getline(in, l);)
      lines.push_back(l);
  }
  const std::vector<std::string> tokens = {"-1", "0", "1e18", "nan", "inf", "99999999999",
                                           "4294967297", "x", "", "2.2", "11"};
  std::mt19937 rng(7);
  int          mutants = 0, loaded = 0;
  const auto   t0      = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() <
         fuzz_seconds())
    {
      auto l = lines;
      for (int c = 0, n = 1 + static_cast<int>(rng() % 4); c < n; ++c)
        {
          const size_t i = rng() % l.size();
          switch (rng() % 4)
            {
              case 0: l.erase(l.begin() + i); break;                   // a line lost
              case 1: l.insert(l.begin() + i, l[rng() % l.size()]); break; // one repeated
              case 2: l.resize(i + 1); break;                           // truncated
              default: {                                                // a token replaced
                std::istringstream       in(l[i]);
                std::vector<std::string> words;
                for (std::string w; in >> w;)
                  words.push_back(w);
                if (!words.empty())
                  words[rng() % words.size()] = tokens[rng() % tokens.size()];
                std::string joined;
                for (const auto &w : words)
                  joined += (joined.empty() ? "" : " ") + w;
                l[i] = joined;
              }
            }
        }
      std::string text;
      for (const auto &x : l)
        text += x + "\n";
      loaded += load_mesh(text);
      ++mutants;
    }
  std::printf("mesh loader: %d random mutants in %.0f s, %d loaded\n", mutants, fuzz_seconds(),
              loaded);
  EXPECT_GT(mutants, 10);
}

// ---- writers against a failing disk ----

namespace
{
  // Limits this process's file size (RLIMIT_FSIZE) for the scope: a write past it fails with
  // EFBIG, as on a full disk. SIGXFSZ is ignored so that the failure is a return value.
  struct FileSizeLimit
  {
    rlimit old{};
    explicit FileSizeLimit(const rlim_t bytes)
    {
      std::signal(SIGXFSZ, SIG_IGN);
      getrlimit(RLIMIT_FSIZE, &old);
      rlimit lim = old;
      lim.rlim_cur = bytes;
      setrlimit(RLIMIT_FSIZE, &lim);
    }
    ~FileSizeLimit()
    {
      setrlimit(RLIMIT_FSIZE, &old);
    }
  };
} // namespace

TEST(Writers, AFailedWriteIsAnIoErrorAndLeavesNothingUnderTheFinalName)
{
  const std::vector<double> big(200000, 1.0); // 1.6 MB
  // A large dataset fails in the write itself; many small ones only when HDF5 flushes its
  // cache at commit; a chunked one written in rows (the precompute's H) in write_rows or flush,
  // through HDF5 or directly (raw chunks).
  // Each must be an IoError, with neither the final name nor a part left.
  for (const int how : {0, 1, 2, 3})
    {
      const auto path = tmp("full_disk_" + std::to_string(how) + ".h5");
      fs::remove(path);
      bool io_error = false;
      try
        {
          FileSizeLimit limit(64 * 1024);
          h5::Writer    w(path);
          if (how == 0)
            w.write("/d", {big.size()}, big.data());
          else if (how == 1)
            for (int i = 0; i < 40; ++i)
              w.write("/d" + std::to_string(i), {500}, big.data());
          else
            {
              // 3: raw chunks, written directly (past the page cache) where the disk allows.
              w.create_dataset("/H", {400, 1000}, true, 10, how == 3); // 80 kB chunks
              for (hsize_t row = 0; row < 400; row += 10)
                {
                  w.write_rows("/H", row, 10, big.data());
                  w.flush();
                }
            }
          w.commit();
        }
      catch (const IoError &)
        {
          io_error = true;
        }
      EXPECT_TRUE(io_error) << how;
      EXPECT_FALSE(fs::exists(path)) << how;
      EXPECT_FALSE(fs::exists(path + ".part")) << how;
      EXPECT_FALSE(fs::exists(path + ".lock")) << how;
    }
  const auto csv = tmp("full_disk.csv");
  fs::remove(csv);
  {
    FileSizeLimit limit(64 * 1024);
    EXPECT_THROW(write_csv(csv, {"a"}, {big}), IoError);
    EXPECT_THROW(write_text_file(csv, std::string(100000, 'x')), IoError);
  }
  EXPECT_FALSE(fs::exists(csv));
  EXPECT_FALSE(fs::exists(csv + ".part"));
}

// Raw chunks (create_dataset(..., raw_chunks), the precompute's H): write_rows writes whole
// chunks to their places in the file with O_DIRECT, the bytes past the last whole sector
// plainly. Sizes that leave such bytes in every chunk (66012-byte rows of floats in 3-row
// chunks, the last chunk one row of three; 66400-byte rows of doubles one per chunk) read
// back exactly, as from a file written through HDF5; a partial file from before (chunks
// without a place) is finished through HDF5.
TEST(Writers, RawChunksReadBackExactlyWithOrWithoutTheDirectPath)
{
  std::mt19937                          gen(3);
  std::uniform_real_distribution<float> u(-1, 1);
  constexpr hsize_t                     row_f = 3 * 5501, row_d = 8300;
  std::vector<float>                    f(7 * row_f);
  for (auto &x : f)
    x = u(gen);
  std::vector<double> d(5 * row_d);
  for (auto &x : d)
    x = u(gen);
  const auto write = [&](const std::string &path, const bool raw) {
    fs::remove(path);
    h5::Writer w(path);
    w.create_dataset("/f", {7, 3, 5501}, false, 3, raw);
    w.create_dataset("/d", {5, row_d}, true, 1, raw);
    w.write_rows("/f", 3, 3, f.data() + 3 * row_f); // out of order, as chunks finish
    w.write_rows("/f", 0, 3, f.data());
    w.write_rows("/f", 6, 1, f.data() + 6 * row_f); // the last chunk: one row of three
    for (hsize_t r = 0; r < 5; r += 1)
      w.write_rows("/d", r, 1, d.data() + r * row_d);
    const std::size_t direct = w.bytes_written_directly();
    w.commit();
    const h5::Reader r(path);
    EXPECT_EQ(r.read_float("/f", {7, 3, 5501}), f) << path;
    EXPECT_EQ(r.read_double("/d", {5, row_d}), d) << path;
    return direct;
  };
  const std::size_t all = f.size() * sizeof(float) + d.size() * sizeof(double);
  EXPECT_EQ(write(tmp("through_hdf5.h5"), false), 0u);
  const std::size_t direct = write(tmp("raw.h5"), true);
  // Whether this folder's file system takes O_DIRECT at all (tmpfs before Linux 6.6 does not).
  const int probe = ::open(tmp("raw.h5").c_str(), O_RDONLY | O_DIRECT);
  if (probe < 0)
    std::cout << "note: this file system refuses O_DIRECT; raw chunks went through HDF5\n";
  else
    {
      ::close(probe);
      EXPECT_EQ(direct, all);
    }

  // A partial file with chunks that have no place yet: finished through HDF5.
  const auto path = tmp("resumed.h5");
  fs::remove(path);
  {
    h5::Writer w(path);
    w.create_dataset("/f", {7, 3, 5501}, false, 3, false);
    w.write_rows("/f", 0, 3, f.data());
    w.keep_partial(true);
  }
  {
    h5::Writer w(path, h5::Writer::Mode::resume);
    ASSERT_TRUE(w.resumed());
    w.write_rows("/f", 3, 3, f.data() + 3 * row_f);
    w.write_rows("/f", 6, 1, f.data() + 6 * row_f);
    EXPECT_EQ(w.bytes_written_directly(), 0u);
    w.commit();
  }
  EXPECT_EQ(h5::Reader(path).read_float("/f", {7, 3, 5501}), f);
}

TEST(Writers, ASecondWriterToTheSameOutputIsRefusedAndTheFirstFinishes)
{
  const auto path = tmp("locked.h5");
  fs::remove(path);
  auto first = std::make_unique<h5::Writer>(path, h5::Writer::Mode::resume);
  first->keep_partial(true);
  const std::vector<double> x = {1, 2, 3};
  first->write("/x", {3}, x.data());
  first->flush();
  try
    {
      h5::Writer second(path, h5::Writer::Mode::resume);
      FAIL() << "a second writer took the same output";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("another run is writing"), std::string::npos);
    }
  EXPECT_TRUE(fs::exists(path + ".part")); // the first run's work is untouched
  first->commit();
  first.reset();
  h5::Reader r(path);
  EXPECT_EQ(r.read_double("/x", {3}), x);
  EXPECT_FALSE(fs::exists(path + ".lock")); // released with the writer
}

TEST(Writers, OutputChecksRefuseInputsFoldersAndMissingFolders)
{
  const auto in = tmp("input.h5");
  write_seed_model(in);
  EXPECT_THROW(check_output_file("--out", in, {in}), InputError);
  EXPECT_THROW(check_output_file("--out", tmp(""), {}), InputError);
  EXPECT_THROW(check_output_file("--out", tmp("no/such/folder/x.h5"), {}), InputError);
  EXPECT_NO_THROW(check_output_file("--out", tmp("fine.h5"), {in}));
}
