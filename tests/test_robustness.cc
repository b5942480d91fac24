// Robustness of everything that reads a file or writes one, without deal.II so that CI runs it
// under AddressSanitizer and UndefinedBehaviorSanitizer (scripts/sanitize.sh):
//  - loaders against hostile files: a seed corpus the tests make (a small impulse-response
//    model, its compressed form, a virtual-DOF model, a gmsh mesh), every dataset and
//    attribute mutated in turn in every way that broke a loader before, and stored anew in
//    every HDF5 type class and dataspace (EveryStorage), then random mutations for a fixed
//    time. A loaded mutant is checked for consistency and run by the runtime; a refused one
//    must be an InputError naming the file (and the field, where its kind changed). Never a
//    crash, a sanitizer report or another exception;
//  - writers against a failing disk (RLIMIT_FSIZE: writes past the limit fail with EFBIG, as on
//    a full disk), at limits swept over each output's length, each run in a child process:
//    an IoError naming the file, and nothing under the final name, no part file, no lock;
//  - output locks and output-path checks.
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/plane_interaction.h>
#include <irdm/point_interaction.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm/response_exchange.h>
#include <irdm/state_space_interaction.h>
#include <irdm/state_space_model.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>
#include <irdm_common/report_stamp.h>
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
#include <sys/wait.h>
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

  // A realization of the seed model identified from its H, its outputs projected (the
  // contact rows and one direction more), so that the basis is in the file.
  void
  write_seed_state_space(const std::string &model_path, const std::string &path)
  {
    fs::remove(path);
    EraOptions o;
    o.order             = 6;
    o.output_directions = 1;
    save_state_space_model(identify_era(load_model(model_path), o), model_path, path);
  }

  // A small exchange file (what irdm import reads): 3 inputs among 4 outputs, T = 6, per
  // unit impulse, with the output index and the triangles.
  // A reduced nonlinear model of one tetrahedron (its base vertex fixed), r = 2, every
  // element; and with a cubature of that element.
  void
  write_seed_reduced(const std::string &path, const bool cubature)
  {
    fs::remove(path);
    h5::Writer w(path);
    w.attribute("/", "format", std::string("irdm-reduced-model"));
    w.attribute("/", "format_version", 1LL);
    w.attribute("/", "law", std::string("neo_hookean"));
    w.attribute("/", "mesh_hash", std::string("0123456789abcdef"));
    for (const auto &[name, value] :
         std::vector<std::pair<const char *, double>>{{"time_step_s", 0.002}, {"alpha_m", 0.1},
                                                      {"alpha_f", 0.2}, {"gamma", 0.6}, {"beta", 0.3},
                                                      {"rayleigh_alpha_1_s", 0.5}, {"rayleigh_beta_s", 1e-3},
                                                      {"lame_mu_Pa", 700}, {"lame_lambda_Pa", 2800},
                                                      {"default_penalty_Pa_m", 1e6}})
      w.attribute("/", name, value);
    const std::vector<double> xyz = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
    // Rows of fixed vertex 0 zero; the two fields move the apex and stretch the base.
    std::vector<double> basis(12 * 2, 0.0);
    basis[9 * 2 + 0] = basis[11 * 2 + 0] = 1; // apex x and z, field 0
    basis[3 * 2 + 1] = basis[7 * 2 + 1] = 1;  // vertex 1 x, vertex 2 y, field 1
    w.create_group("/basis");
    w.write("/basis/shapes", {12, 2}, basis.data());
    w.attribute("/basis", "lowest_modes", 1LL);
    w.attribute("/basis", "residual_modes", 1LL);
    w.attribute("/basis", "modal_derivatives", 0LL);
    w.create_group("/mesh");
    const std::vector<long long> tet = {0, 1, 2, 3};
    // grad N_i of the unit-corner tetrahedron scaled by 0.1: N_0 = 1 - x - y - z (over 0.1).
    const std::vector<double> grads = {-10, -10, -10, 10, 0, 0, 0, 10, 0, 0, 0, 10};
    const double              volume = 0.1 * 0.1 * 0.1 / 6;
    w.write("/mesh/tetrahedra", {1, 4}, tet.data());
    w.write("/mesh/gradients", {1, 4, 3}, grads.data());
    w.write("/mesh/volumes", {1}, &volume);
    w.create_group("/surface");
    const std::vector<long long> vertices = {0, 1, 2, 3}, tags = {10, 11, 12, 13},
                                 tri = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2},
                                 free = {0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1};
    const std::vector<double>    area = {0.004, 0.004, 0.004, 0.004};
    w.write("/surface/vertices", {4}, vertices.data());
    w.write("/surface/node_tags", {4}, tags.data());
    w.write("/surface/coordinates", {4, 3}, xyz.data());
    w.write("/surface/triangles", {4, 3}, tri.data());
    w.write("/surface/lumped_area_m2", {4}, area.data());
    w.write("/surface/free", {4, 3}, free.data());
    if (cubature)
      {
        w.create_group("/cubature");
        const long long element = 0;
        const double    weight  = 1.0;
        w.write("/cubature/elements", {1}, &element);
        w.write("/cubature/weights", {1}, &weight);
        w.attribute("/cubature", "training_error", 0.0);
      }
    w.commit();
  }

  void
  write_seed_exchange(const std::string &path)
  {
    fs::remove(path);
    const unsigned nv = 4, ni = 3, T = 6, nout = 3 * nv, nin = 3 * ni;
    h5::Writer     w(path);
    w.attribute("/", "format", std::string("irdm-responses"));
    w.attribute("/", "format_version", 1LL);
    w.attribute("/", "time_step_s", 0.002);
    w.attribute("/", "convention", std::string("unit_impulse"));
    w.attribute("/", "source", std::string("the robustness test"));
    const std::vector<double> xyz = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
    w.create_group("/outputs");
    w.write("/outputs/coordinates", {nv, 3}, xyz.data());
    w.create_group("/inputs");
    w.write("/inputs/coordinates", {ni, 3}, xyz.data());
    const std::vector<long long> io = {0, 1, 2};
    w.write("/inputs/output_index", {ni}, io.data());
    w.create_group("/surface");
    const std::vector<long long> tri = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
    w.write("/surface/triangles", {4, 3}, tri.data());
    std::vector<double> H(static_cast<size_t>(nin) * T * nout);
    for (unsigned a = 0; a < nin; ++a)
      for (unsigned t = 0; t < T; ++t)
        for (unsigned b = 0; b < nout; ++b)
          H[(static_cast<size_t>(a) * T + t) * nout + b] =
            std::exp(-static_cast<double>(t) / 3.0) * ((a == b ? 0.5 : 0) + 5e-3 * std::cos(a + b + t));
    w.write("/responses", {nin, T, nout}, H.data());
    w.commit();
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

  // ---- every HDF5 type class and every dataspace ----

  // A field (attribute or dataset) stored anew with another type and dataspace. What it
  // holds, as written: the field's own values (its text for a string, its numbers otherwise),
  // converted by HDF5 where the new type is a number, repeated or cut to the new extent.
  enum class Extent
  {
    natural,      // an attribute's one value, a dataset's own shape
    one_element,  // simple, (1)
    two_elements, // simple, (2)
    empty,        // simple, (0)
    null,         // H5S_NULL
    scalar        // H5S_SCALAR
  };

  enum class Class
  {
    fixed_string,
    variable_string,
    number,
    compound,
    enumeration,
    opaque,
    reference,
    bitfield,
    array,
    sequence
  };

  struct Storage
  {
    std::string name;
    Class       kind;
    Extent      extent = Extent::natural;
    hid_t       base   = -1; // number: its HDF5 type; fixed string: unused
    H5T_str_t   pad    = H5T_STR_NULLTERM;
    H5T_cset_t  cset   = H5T_CSET_ASCII;
  };

  void
  PrintTo(const Storage &k, std::ostream *os)
  {
    *os << k.name;
  }

  // An IEEE-like float of 16 bits (1 sign, 5 exponent, 10 mantissa bits): a float class HDF5
  // converts, but no float this program reads.
  hid_t
  half_float()
  {
    const hid_t t = H5Tcopy(H5T_IEEE_F32LE);
    H5Tset_fields(t, 15, 10, 5, 0, 10);
    H5Tset_offset(t, 0);
    H5Tset_precision(t, 16);
    H5Tset_size(t, 2);
    H5Tset_ebias(t, 15);
    return t;
  }

  // Every kind of storage a field is turned into: each HDF5 type class, strings of every kind,
  // padding and set, numbers of every width, then every dataspace.
  std::vector<Storage>
  storage_kinds()
  {
    std::vector<Storage> k = {
      {"fixed_string_nullterm", Class::fixed_string},
      {"fixed_string_spacepad", Class::fixed_string, Extent::natural, -1, H5T_STR_SPACEPAD},
      {"fixed_string_utf8", Class::fixed_string, Extent::natural, -1, H5T_STR_NULLTERM,
       H5T_CSET_UTF8},
      {"variable_string", Class::variable_string},
      {"variable_string_utf8", Class::variable_string, Extent::natural, -1, H5T_STR_NULLTERM,
       H5T_CSET_UTF8},
      {"int8", Class::number, Extent::natural, H5T_STD_I8LE},
      {"uint8", Class::number, Extent::natural, H5T_STD_U8LE},
      {"int16", Class::number, Extent::natural, H5T_STD_I16LE},
      {"uint16", Class::number, Extent::natural, H5T_STD_U16LE},
      {"int32_big_endian", Class::number, Extent::natural, H5T_STD_I32BE},
      {"uint32", Class::number, Extent::natural, H5T_STD_U32LE},
      {"int64", Class::number, Extent::natural, H5T_STD_I64LE},
      {"uint64", Class::number, Extent::natural, H5T_STD_U64LE},
      {"float32", Class::number, Extent::natural, H5T_IEEE_F32LE},
      {"float64_big_endian", Class::number, Extent::natural, H5T_IEEE_F64BE},
      {"float16", Class::number, Extent::natural, -2},
      {"compound", Class::compound},
      {"enum", Class::enumeration},
      {"opaque", Class::opaque},
      {"object_reference", Class::reference},
      {"bitfield", Class::bitfield},
      {"array_type", Class::array},
      {"sequence", Class::sequence},
    };
    for (const auto &[name, extent] :
         std::vector<std::pair<std::string, Extent>>{{"one_element", Extent::one_element},
                                                     {"two_elements", Extent::two_elements},
                                                     {"empty", Extent::empty},
                                                     {"null", Extent::null},
                                                     {"scalar", Extent::scalar}})
      {
        // Each dataspace with the field's own kind of value: a fixed string or a double (a
        // scalar string is what the seeds' string attributes are already).
        if (extent != Extent::scalar)
          k.push_back({name + "_of_strings", Class::fixed_string, extent});
        k.push_back({name + "_of_numbers", Class::number, extent, H5T_IEEE_F64LE});
      }
    return k;
  }

  // What a field held in the seed: its text if a string, its numbers otherwise, and its shape.
  struct FieldValues
  {
    bool                 is_string = false;
    std::string          text;
    std::vector<double>  numbers;
    std::vector<hsize_t> dims; // empty: a scalar
  };

  // Opens the field (attribute or dataset) of item in f; out: its type and space.
  hid_t
  open_field(const hid_t f, const Item &item, hid_t &type, hid_t &space)
  {
    if (item.attribute.empty())
      {
        const hid_t set = H5Dopen2(f, item.object.c_str(), H5P_DEFAULT);
        type            = H5Dget_type(set);
        space           = H5Dget_space(set);
        return set;
      }
    const hid_t attr = H5Aopen_by_name(f, item.object.c_str(), item.attribute.c_str(),
                                       H5P_DEFAULT, H5P_DEFAULT);
    type  = H5Aget_type(attr);
    space = H5Aget_space(attr);
    return attr;
  }

  void
  close_field(const Item &item, const hid_t id, const hid_t type, const hid_t space)
  {
    H5Tclose(type);
    H5Sclose(space);
    item.attribute.empty() ? H5Dclose(id) : H5Aclose(id);
  }

  herr_t
  read_field(const Item &item, const hid_t id, const hid_t mem, void *buffer)
  {
    return item.attribute.empty() ? H5Dread(id, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer)
                                  : H5Aread(id, mem, buffer);
  }

  // The seed's field, read by HDF5 itself (the seeds hold fixed strings and numbers only).
  FieldValues
  field_values(const std::string &path, const Item &item)
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t       type, space;
    const hid_t id = open_field(f, item, type, space);
    FieldValues v;
    const int   rank = H5Sget_simple_extent_ndims(space);
    v.dims.resize(std::max(rank, 0));
    if (rank > 0)
      H5Sget_simple_extent_dims(space, v.dims.data(), nullptr);
    v.is_string = H5Tget_class(type) == H5T_STRING;
    if (v.is_string)
      {
        v.text.assign(H5Tget_size(type), '\0');
        read_field(item, id, type, v.text.data());
        v.text.resize(std::min(v.text.size(), v.text.find('\0')));
      }
    else
      {
        v.numbers.resize(static_cast<size_t>(std::max<hssize_t>(1, H5Sget_simple_extent_npoints(space))));
        read_field(item, id, H5T_NATIVE_DOUBLE, v.numbers.data());
      }
    close_field(item, id, type, space);
    H5Fclose(f);
    return v;
  }

  // The mutant's type for kind k (owned by the caller); for a fixed string, `bytes` long.
  hid_t
  make_type(const Storage &k, const std::size_t bytes)
  {
    hid_t t = -1;
    switch (k.kind)
      {
        case Class::fixed_string:
        case Class::variable_string:
          t = H5Tcopy(H5T_C_S1);
          H5Tset_size(t, k.kind == Class::variable_string ? H5T_VARIABLE : bytes);
          H5Tset_strpad(t, k.pad);
          H5Tset_cset(t, k.cset);
          return t;
        case Class::number:
          return k.base == -2 ? half_float() : H5Tcopy(k.base);
        case Class::compound:
          t = H5Tcreate(H5T_COMPOUND, 16);
          H5Tinsert(t, "a", 0, H5T_NATIVE_DOUBLE);
          H5Tinsert(t, "b", 8, H5T_NATIVE_DOUBLE);
          return t;
        case Class::enumeration: {
          t           = H5Tenum_create(H5T_NATIVE_INT);
          const int a = 0, b = 1;
          H5Tenum_insert(t, "a", &a);
          H5Tenum_insert(t, "b", &b);
          return t;
        }
        case Class::opaque:
          t = H5Tcreate(H5T_OPAQUE, 8);
          H5Tset_tag(t, "eight bytes");
          return t;
        case Class::reference:
          return H5Tcopy(H5T_STD_REF_OBJ);
        case Class::bitfield:
          return H5Tcopy(H5T_STD_B8LE);
        case Class::array: {
          const hsize_t two = 2;
          return H5Tarray_create2(H5T_NATIVE_DOUBLE, 1, &two);
        }
        case Class::sequence:
          return H5Tvlen_create(H5T_NATIVE_DOUBLE);
      }
    return t;
  }

  // The shape a field of shape `natural` takes with extent e (empty: a scalar; (0) for null).
  std::vector<hsize_t>
  dims_of(const Extent e, const std::vector<hsize_t> &natural)
  {
    switch (e)
      {
        case Extent::natural:
          return natural;
        case Extent::one_element:
          return {1};
        case Extent::two_elements:
          return {2};
        case Extent::scalar:
          return {};
        default:
          return {0};
      }
  }

  // Stores item anew in path with storage k. Returns true if the stored values are the seed's
  // (the same text in another string kind; the same numbers, exactly, in another width or byte
  // order; one value in a one-element array): a loader must then load the seed's model.
  bool
  restore_as(const std::string &path, const Item &item, const Storage &k)
  {
    const FieldValues v = field_values(path, item);
    const hid_t       f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const bool is_attribute = !item.attribute.empty();
    if (is_attribute)
      H5Adelete_by_name(f, item.object.c_str(), item.attribute.c_str(), H5P_DEFAULT);
    else
      H5Ldelete(f, item.object.c_str(), H5P_DEFAULT);

    const std::vector<hsize_t> dims  = dims_of(k.extent, v.dims);
    const hid_t                space = k.extent == Extent::null ? H5Screate(H5S_NULL)
                                       : dims.empty()
                                         ? H5Screate(H5S_SCALAR)
                                         : H5Screate_simple(static_cast<int>(dims.size()),
                                                            dims.data(), nullptr);
    size_t n = 1;
    for (const auto d : dims)
      n *= d;
    const std::vector<double> numbers =
      v.is_string ? std::vector<double>{std::atof(v.text.c_str())} : v.numbers;
    std::string text = v.text;
    if (!v.is_string)
      {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.17g", v.numbers.empty() ? 0.0 : v.numbers[0]);
        text = buf;
      }
    // Room to spare: the padding shows (NULs, or spaces that a reader must strip).
    const std::size_t string_bytes = text.size() + 4;
    const hid_t       type = make_type(k, std::max<std::size_t>(1, string_bytes));
    const hid_t id = is_attribute ? H5Acreate_by_name(f, item.object.c_str(), item.attribute.c_str(),
                                                      type, space, H5P_DEFAULT, H5P_DEFAULT,
                                                      H5P_DEFAULT)
                                  : H5Dcreate2(f, item.object.c_str(), type, space, H5P_DEFAULT,
                                               H5P_DEFAULT, H5P_DEFAULT);
    const auto write = [&](const hid_t mem, const void *data) {
      if (n > 0 && k.extent != Extent::null)
        is_attribute ? H5Awrite(id, mem, data)
                     : H5Dwrite(id, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
    };
    std::vector<double> values(n);
    for (size_t i = 0; i < n; ++i)
      values[i] = numbers.empty() ? 0 : numbers[i % numbers.size()];
    switch (k.kind)
      {
        case Class::fixed_string: {
          std::string padded(type >= 0 ? H5Tget_size(type) : 1, k.pad == H5T_STR_SPACEPAD ? ' ' : '\0');
          padded.replace(0, std::min(text.size(), padded.size()), text.substr(0, padded.size()));
          std::string all;
          for (size_t i = 0; i < n; ++i)
            all += padded;
          write(type, all.data());
          break;
        }
        case Class::variable_string: {
          std::vector<const char *> p(n, text.c_str());
          write(type, p.data());
          break;
        }
        case Class::number:
          write(H5T_NATIVE_DOUBLE, values.data());
          break;
        case Class::compound:
        case Class::array: {
          std::vector<double> pairs;
          for (const double x : values)
            pairs.insert(pairs.end(), {x, x});
          write(type, pairs.data());
          break;
        }
        case Class::enumeration: {
          std::vector<int> e(n, 1);
          write(type, e.data());
          break;
        }
        case Class::opaque:
        case Class::bitfield: {
          std::vector<unsigned char> bytes(n * H5Tget_size(type), 0x5a);
          write(type, bytes.data());
          break;
        }
        case Class::reference: {
          std::vector<hobj_ref_t> refs(n);
          for (auto &r : refs)
            H5Rcreate(&r, f, "/", H5R_OBJECT, -1);
          write(type, refs.data());
          break;
        }
        case Class::sequence: {
          std::vector<hvl_t> seq(n);
          for (size_t i = 0; i < n; ++i)
            seq[i] = {1, &values[i]};
          write(type, seq.data());
          break;
        }
      }
    close_field(item, id, type, space);

    // The same values? Read back by HDF5 itself (numbers), or by construction (text).
    // A 16-bit float is no float this program reads (h5.h), whatever it holds.
    bool same = k.base != -2 && (k.extent == Extent::natural ||
                (is_attribute && (k.extent == Extent::one_element || k.extent == Extent::scalar)));
    if (k.kind == Class::fixed_string || k.kind == Class::variable_string)
      same = same && v.is_string;
    else if (k.kind == Class::number && !v.is_string && same)
      {
        hid_t       t2, s2;
        const hid_t again = open_field(f, item, t2, s2);
        std::vector<double> back(n);
        same = read_field(item, again, H5T_NATIVE_DOUBLE, back.data()) >= 0 &&
               back.size() == v.numbers.size();
        for (size_t i = 0; same && i < back.size(); ++i)
          same = back[i] == v.numbers[i] || (std::isnan(back[i]) && std::isnan(v.numbers[i]));
        close_field(item, again, t2, s2);
      }
    else
      same = false;
    H5Fclose(f);
    return same;
  }

  // ---- what each loader must survive ----

  // What a loader made of a file: loaded or refused (with the InputError's message), and, if
  // loaded, a fingerprint of the model (its strings, and the runtime's surface after a press)
  // that two loads of the same content share.
  struct Outcome
  {
    bool        loaded = false;
    std::string fingerprint, error;
  };

  using Loader = std::function<Outcome(const std::string &)>;

  std::string
  fingerprint_of(const ModelFrame &m, const std::vector<double> &surface)
  {
    std::ostringstream s;
    s << m.integrator << '|' << m.mesh_hash << '|' << m.storage_on_disk << '|' << m.time_step
      << '|' << m.length << '|';
    for (const auto &n : m.surface_names)
      s << n << ',';
    s.precision(17);
    for (const double x : surface)
      s << x << ' ';
    return s.str();
  }

  // Independent of the loaders' own checks: every index in range, every size as the counts
  // say, every number finite where the runtime computes with it.
  void
  expect_consistent(const ModelFrame &m)
  {
    const size_t nv = m.output_node_tags.size(), ni = m.input_node_tags.size();
    EXPECT_TRUE(m.time_step > 0 && std::isfinite(m.time_step));
    EXPECT_GE(m.length, 1u);
    EXPECT_EQ(m.n_outputs, 3 * nv);
    EXPECT_EQ(m.n_inputs, 3 * ni);
    EXPECT_EQ(m.output_coordinates.size(), nv);
    EXPECT_EQ(m.input_output_index.size(), ni);
    for (const auto i : m.input_output_index)
      EXPECT_LT(i, nv);
    EXPECT_EQ(m.output_input_index.size(), nv);
    for (const int i : m.output_input_index)
      EXPECT_TRUE(i == -1 || (i >= 0 && static_cast<size_t>(i) < ni));
    EXPECT_EQ(m.triangle_surface.size(), m.triangles.size());
    for (const auto &t : m.triangles)
      for (const auto v : t)
        EXPECT_LT(v, nv);
    for (const int s : m.triangle_surface)
      EXPECT_TRUE(s >= 0 && static_cast<size_t>(s) < m.surface_names.size());
    if (m.free_body)
      EXPECT_TRUE(m.mass > 0 && std::isfinite(m.mass));
  }

  void
  expect_consistent(const ImpulseResponseModel &m)
  {
    expect_consistent(static_cast<const ModelFrame &>(m));
    const size_t h = static_cast<size_t>(m.n_inputs) * m.length * m.n_outputs;
    EXPECT_EQ(m.double_storage ? m.h_double.size() : m.h_float.size(), h);
    if (m.modes.n_modes > 0)
      {
        EXPECT_EQ(m.modes.shapes.size(), static_cast<size_t>(m.n_outputs) * m.modes.n_modes);
        EXPECT_EQ(m.modes.step.size(), 15u * m.modes.n_modes);
        EXPECT_EQ(m.modes.frequency_hz.size(), m.modes.n_modes);
      }
  }

  void
  expect_consistent(const RepresentativeModel &m)
  {
    expect_consistent(static_cast<const ModelFrame &>(m));
    ASSERT_EQ(m.first_representative.size(), m.n_inputs + 1u);
    EXPECT_EQ(m.representatives.size(),
              static_cast<size_t>(m.first_representative.back()) * m.length);
    const size_t terms = static_cast<size_t>(m.n_inputs) * m.n_outputs * m.blend;
    EXPECT_EQ(m.term_representative.size(), terms);
    EXPECT_EQ(m.term_delay.size(), terms);
    EXPECT_EQ(m.term_amplitude.size(), terms);
    for (const auto d : m.term_delay)
      EXPECT_LE(d, m.delay_span);
    EXPECT_LT(m.delay_span, m.length);
  }

  void
  expect_consistent(const StateSpaceModel &m)
  {
    expect_consistent(static_cast<const ModelFrame &>(m));
    EXPECT_EQ(m.real_poles.size() + 2 * (m.complex_poles.size() / 2), m.order);
    EXPECT_EQ(m.b.size(), static_cast<size_t>(m.n_inputs) * m.order);
    EXPECT_EQ(m.c.size(), static_cast<size_t>(m.output_dimension) * m.order);
    EXPECT_TRUE(m.output_basis.empty() ||
                m.output_basis.size() == static_cast<size_t>(m.n_outputs) * m.output_dimension);
    ASSERT_EQ(m.contact_direction.size(), m.n_inputs);
    for (const unsigned d : m.contact_direction)
      EXPECT_LT(d, m.output_dimension);
    EXPECT_EQ(m.d.size(), static_cast<size_t>(m.n_inputs) * m.n_outputs);
  }

  // Loads with load_fn and, if that succeeds, checks the model and drives Interaction for 3 T
  // steps with a probe pressing triangle 0 (lifted if it cannot touch there), then updates
  // the surface. Only an InputError may escape the loader; anything else fails the test.
  template <typename Interaction, typename LoadFn>
  Outcome
  load_and_run(const std::string &path, const LoadFn &load_fn)
  {
    Outcome out;
    try
      {
        const auto m = load_fn(path);
        expect_consistent(m);
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
        out.loaded      = true;
        out.fingerprint = fingerprint_of(m, u);
      }
    catch (const InputError &e)
      {
        out.error = e.what();
      }
    return out;
  }

  // The uncompressed model runs twice: by direct convolution, and (if the file holds a modal
  // realization) as the modal model made from it.
  Outcome
  load_and_run_model(const std::string &path)
  {
    Outcome direct =
      load_and_run<PointInteraction>(path, [](const std::string &f) { return load_model(f); });
    if (direct.loaded)
      {
        const ImpulseResponseModel m = load_model(path);
        if (m.modes.n_modes > 0)
          direct.fingerprint +=
            "|modal " + load_and_run<ModalInteraction>(path, [&](const std::string &) {
                          ModalModelOptions o;
                          o.surface_modes = m.modes.n_modes;
                          return make_modal_model(m, o);
                        }).fingerprint;
      }
    return direct;
  }

  Outcome
  load_and_run_compressed(const std::string &path)
  {
    return load_and_run<RepresentativeInteraction>(
      path, [](const std::string &f) { return load_representative_model(f); });
  }

  Outcome
  load_and_run_state_space(const std::string &path)
  {
    return load_and_run<StateSpaceInteraction>(
      path, [](const std::string &f) { return load_state_space_model(f); });
  }

  // An exchange file imported (irdm import), then the model it made run as any model is.
  Outcome
  import_and_run(const std::string &path)
  {
    const std::string model = tmp("imported_mutant.h5");
    fs::remove(model);
    try
      {
        import_responses(path, model);
      }
    catch (const InputError &e)
      {
        Outcome o;
        o.error = e.what();
        return o;
      }
    Outcome o = load_and_run_model(model);
    EXPECT_TRUE(o.loaded) << "an import wrote a model that does not load: " << o.error;
    return o;
  }

  // A plane pressing the apex in and out, with a vertex force: every step finite or counted.
  Outcome
  load_and_run_reduced(const std::string &path)
  {
    Outcome out;
    try
      {
        const ReducedNonlinearModel m = load_reduced_nonlinear_model(path);
        EXPECT_EQ(m.basis.size(), 3ull * m.n_vertices * m.size);
        for (const auto &t : m.tetrahedra)
          for (const auto v : t)
            EXPECT_LT(v, m.n_vertices);
        for (const auto e : m.cubature_elements)
          EXPECT_LT(e, m.elements.size());
        for (const auto &t : m.triangles)
          for (const auto v : t)
            EXPECT_LT(v, m.surface_vertex.size());
        ReducedNonlinearBody body(m);
        std::ostringstream   print;
        print.precision(17);
        print << m.time_step << '|' << m.size << '|';
        ReducedPlane             plane;
        plane.normal = {0, 0, -1};
        const ReducedVertexForce push{3, {0.01, 0, 0}};
        std::vector<double>      u(3 * m.surface_vertex.size());
        for (int s = 0; s < 12; ++s)
          {
            plane.point = {0, 0, 0.1 - 0.002 * std::sin(0.3 * s)};
            print << body.step(&plane, 1, &push, 1) << ' ' << body.plane_force(0)[2] << ' ';
          }
        body.surface_displacement(u.data());
        for (const double x : u)
          print << x << ' ';
        out.loaded      = true;
        out.fingerprint = print.str();
      }
    catch (const InputError &e)
      {
        out.error = e.what();
      }
    return out;
  }

  // A wall along a direction between the dome's, pressing in and out, with both mappings.
  Outcome
  load_and_run_virtual_dofs(const std::string &path)
  {
    Outcome out;
    try
      {
        const VirtualDofModel m = load_virtual_dof_model(path);
        const size_t          K = m.n_orientations, T = m.length, n = m.n_surface;
        EXPECT_EQ(m.directions.size(), K);
        EXPECT_EQ(m.surface_response.size(), K * T * 3 * n);
        EXPECT_EQ(m.dof_response.size(), K * T * K);
        EXPECT_EQ(m.coordinates.size(), n);
        EXPECT_EQ(m.fixed.size(), n);
        for (const auto &t : m.dome_triangles)
          for (const auto k : t)
            EXPECT_LT(k, K);
        for (const auto &t : m.triangles)
          for (const auto v : t)
            EXPECT_LT(v, n);
        std::ostringstream print;
        print.precision(17);
        print << m.integrator << '|' << m.mesh_hash << '|' << m.time_step << '|' << m.band << '|';
        for (const auto mapping : {OrientationMapping::nearest, OrientationMapping::interpolated})
          {
            PlaneInteraction             wall(m, mapping);
            const std::array<double, 3> d = {0.48, 0.6, -0.64};
            for (int s = 0; s < 3 * static_cast<int>(m.length); ++s)
              print << wall.step(d, 0.01 * std::sin(0.3 * s)) << ' ';
            for (const double x : wall.update_surface())
              print << x << ' ';
          }
        out.loaded      = true;
        out.fingerprint = print.str();
      }
    catch (const InputError &e)
      {
        out.error = e.what();
      }
    return out;
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
    // A refusal names the file (the field is named where the field's kind was changed:
    // EveryStorage below).
    const auto count = [&](const Outcome &o) {
      ++tally.mutants;
      (o.loaded ? tally.loaded : tally.refused) += 1;
      if (!o.loaded)
        EXPECT_NE(o.error.find(mutant), std::string::npos) << "no file named: " << o.error;
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
    const auto                kinds  = storage_kinds();
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
            if (c == 0 && rng() % 4 == 0) // a field of the seed stored in another kind
              {
                restore_as(mutant, item, kinds[rng() % kinds.size()]);
                continue;
              }
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
        const Outcome o = load(mutant);
        ++tally.mutants;
        (o.loaded ? tally.loaded : tally.refused) += 1;
        if (!o.loaded)
          EXPECT_NE(o.error.find(mutant), std::string::npos) << "no file named: " << o.error;
      }
    return tally;
  }

  // Every field of the seed stored as kind k, one at a time. A field that keeps its values
  // (restore_as) loads the seed's model. A field that matters (without it the file is refused
  // or loads another model) stored as another class of value (a number for a string, a
  // compound for a number, ...) or with another extent is refused, and the message names the
  // file and the field. Anything else loads a consistent model or is refused.
  void
  expect_every_field_survives(const Storage &k, const std::string &seed, const Loader &load)
  {
    const Outcome original = load(seed);
    ASSERT_TRUE(original.loaded) << original.error;
    const auto mutant = tmp("restored.h5");
    int        kept = 0, refused = 0, loaded = 0;
    for (const auto &item : items_of(seed))
      {
        const std::string field = item.attribute.empty()
                                    ? item.object.substr(item.object.rfind('/') + 1)
                                    : item.attribute;
        SCOPED_TRACE(item.object + (item.attribute.empty() ? "" : " @" + item.attribute) +
                     " as " + k.name);
        fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
        if (item.attribute.empty())
          mutate_dataset(mutant, item.object, DataMutation::remove, 0, 0);
        else
          mutate_attribute(mutant, item, AttributeMutation::remove, 0);
        const Outcome without = load(mutant);
        const bool    matters = !without.loaded || without.fingerprint != original.fingerprint;

        fs::copy_file(seed, mutant, fs::copy_options::overwrite_existing);
        const FieldValues v    = field_values(mutant, item);
        const bool        same = restore_as(mutant, item, k);
        const bool is_string   = k.kind == Class::fixed_string || k.kind == Class::variable_string;
        const bool same_class  = is_string ? v.is_string : k.kind == Class::number && !v.is_string;
        const auto dims        = dims_of(k.extent, v.dims);
        const auto one_value   = [](const std::vector<hsize_t> &d) {
          return d.empty() || d == std::vector<hsize_t>{1};
        };
        const bool same_extent = k.extent != Extent::null &&
                                 (dims == v.dims || (!item.attribute.empty() && one_value(dims) &&
                                                     one_value(v.dims)));
        const Outcome o = load(mutant);
        if (same)
          {
            ++kept;
            EXPECT_TRUE(o.loaded) << "the same values stored another way were refused: "
                                  << o.error;
            EXPECT_EQ(o.fingerprint, original.fingerprint) << "the same values loaded otherwise";
          }
        else if (o.loaded)
          {
            ++loaded;
            EXPECT_FALSE(matters && !(same_class && same_extent))
              << "a field the loader reads, stored as something else, loaded";
          }
        else
          {
            ++refused;
            EXPECT_NE(o.error.find(mutant), std::string::npos) << "no file named: " << o.error;
            EXPECT_NE(o.error.find(field), std::string::npos) << "no field named: " << o.error;
          }
      }
    std::printf("%s: %d fields kept their values, %d loaded otherwise, %d refused\n",
                k.name.c_str(), kept, loaded, refused);
  }

  double
  fuzz_seconds()
  {
    const char *s = std::getenv("IRDM_FUZZ_SECONDS");
    return s ? std::atof(s) : 10.0;
  }

  // The two fuzz stages for one loader, with what they did printed for the log.
  void
  expect_structured_mutations_survive(const char *what, const std::string &seed, const Loader &load,
                                      const int at_least = 300)
  {
    ASSERT_TRUE(load(seed).loaded) << "the seed itself does not load";
    const Tally t = structured_mutations(seed, load);
    std::printf("%s: %d structured mutants, %d loaded and ran, %d refused\n", what, t.mutants,
                t.loaded, t.refused);
    EXPECT_GT(t.mutants, at_least); // every field of the seed reached
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

TEST(StateSpaceLoaderFuzz, EveryStructuredMutationLoadsOrIsRefusedClearly)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_state_space.h5");
  write_seed_model(model);
  write_seed_state_space(model, seed);
  expect_structured_mutations_survive("state-space loader", seed, load_and_run_state_space);
}

TEST(StateSpaceLoaderFuzz, RandomMutationsForAFixedTime)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_state_space.h5");
  write_seed_model(model);
  write_seed_state_space(model, seed);
  expect_random_mutations_survive("state-space loader", seed, load_and_run_state_space);
}

TEST(ExchangeImportFuzz, EveryStructuredMutationImportsOrIsRefusedClearly)
{
  const auto seed = tmp("seed_exchange.h5");
  write_seed_exchange(seed);
  expect_structured_mutations_survive("exchange import", seed, import_and_run, 200); // fewer fields
}

TEST(ExchangeImportFuzz, RandomMutationsForAFixedTime)
{
  const auto seed = tmp("seed_exchange.h5");
  write_seed_exchange(seed);
  expect_random_mutations_survive("exchange import", seed, import_and_run);
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

TEST(ReducedLoaderFuzz, EveryStructuredMutationLoadsOrIsRefusedClearly)
{
  for (const bool cubature : {false, true})
    {
      const auto seed = tmp(cubature ? "seed_reduced_cubature.h5" : "seed_reduced.h5");
      write_seed_reduced(seed, cubature);
      expect_structured_mutations_survive("reduced loader", seed, load_and_run_reduced, 150);
    }
}

TEST(ReducedLoaderFuzz, RandomMutationsForAFixedTime)
{
  const auto seed = tmp("seed_reduced_cubature.h5");
  write_seed_reduced(seed, true);
  expect_random_mutations_survive("reduced loader", seed, load_and_run_reduced);
}

// Every field of every file kind stored in every HDF5 type class and dataspace, one kind of
// storage per test (a failing kind is named by its test).
class EveryStorage : public ::testing::TestWithParam<Storage>
{};

TEST_P(EveryStorage, ModelLoaderReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto seed = tmp("seed_model.h5");
  write_seed_model(seed);
  expect_every_field_survives(GetParam(), seed, load_and_run_model);
}

TEST_P(EveryStorage, CompressedLoaderReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_compressed.h5");
  write_seed_model(model);
  write_seed_compressed(model, seed);
  expect_every_field_survives(GetParam(), seed, load_and_run_compressed);
}

TEST_P(EveryStorage, StateSpaceLoaderReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto model = tmp("seed_model.h5"), seed = tmp("seed_state_space.h5");
  write_seed_model(model);
  write_seed_state_space(model, seed);
  expect_every_field_survives(GetParam(), seed, load_and_run_state_space);
}

TEST_P(EveryStorage, ReducedLoaderReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto seed = tmp("seed_reduced_cubature.h5");
  write_seed_reduced(seed, true);
  expect_every_field_survives(GetParam(), seed, load_and_run_reduced);
}

TEST_P(EveryStorage, ExchangeImportReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto seed = tmp("seed_exchange.h5");
  write_seed_exchange(seed);
  expect_every_field_survives(GetParam(), seed, import_and_run);
}

TEST_P(EveryStorage, VirtualDofLoaderReadsTheSameValuesOrRefusesNamingTheField)
{
  const auto seed = tmp("seed_vdof.h5");
  write_seed_virtual_dofs(seed);
  expect_every_field_survives(GetParam(), seed, load_and_run_virtual_dofs);
}

INSTANTIATE_TEST_SUITE_P(Kinds, EveryStorage, ::testing::ValuesIn(storage_kinds()),
                         [](const ::testing::TestParamInfo<Storage> &i) { return i.param.name; });

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

namespace
{
  // Runs `write` in a child process whose files may grow to `limit` bytes. The child's exit
  // status: 0 written, 4 an IoError naming `path`, 5 an IoError naming no file, 2 an
  // InputError, 1 anything else; a signal is 128 + its number.
  int
  write_in_child(const rlim_t limit, const std::string &path, const std::function<void()> &write)
  {
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0)
      {
        int code = 0;
        {
          FileSizeLimit l(limit);
          try
            {
              write();
            }
          catch (const IoError &e)
            {
              code = std::string(e.what()).find(path) != std::string::npos ? 4 : 5;
            }
          catch (const InputError &)
            {
              code = 2;
            }
          catch (...)
            {
              code = 1;
            }
        }
        std::_Exit(code); // no exit handlers: the parent's HDF5 and gtest state stay its own
      }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  // Writes `path` with `write` under file-size limits swept from 0 to the whole file's
  // length (every 512 bytes, at most 300 limits): each run ends written whole (the same size
  // as without a limit) or with an IoError naming the file, and then leaves neither the final
  // name, nor its part file, nor its lock.
  void
  expect_every_failure_point_is_an_io_error(const std::string &path,
                                            const std::function<void()> &write)
  {
    const auto clear = [&] {
      for (const auto &f : {path, path + ".part", path + ".lock"})
        fs::remove(f);
    };
    clear();
    ASSERT_EQ(write_in_child(RLIM_INFINITY, path, write), 0);
    const auto size = fs::file_size(path);
    const auto step = std::max<std::uintmax_t>(512, size / 300);
    int        failed = 0, whole = 0;
    for (std::uintmax_t limit = 0; limit < size; limit += step)
      {
        SCOPED_TRACE("file-size limit " + std::to_string(limit) + " of " + std::to_string(size));
        clear();
        const int status = write_in_child(limit, path, write);
        EXPECT_TRUE(status == 4 || status == 0) << "exit status " << status;
        if (status == 0)
          {
            ++whole;
            EXPECT_EQ(fs::file_size(path), size);
          }
        else
          {
            ++failed;
            EXPECT_FALSE(fs::exists(path));
          }
        EXPECT_FALSE(fs::exists(path + ".part"));
        EXPECT_FALSE(fs::exists(path + ".lock"));
      }
    std::printf("%s: %ju bytes; %d limits failed the write (exit 4), %d let it finish\n",
                fs::path(path).filename().c_str(), size, failed, whole);
    EXPECT_GT(failed, 0);
    clear(); // and once more with room, for the caller to read
    EXPECT_EQ(write_in_child(RLIM_INFINITY, path, write), 0);
  }
} // namespace

// Every operation of the HDF5 writer, in one file: groups, attributes of each kind (and one
// replaced), datasets of each type, small and large, rows through HDF5 and raw chunks written
// directly, a flush, a checked copy of another file's groups and root attributes, the commit.
TEST(Writers, EveryWriterOperationFailsCleanlyAtEveryPointTheDiskCanFill)
{
  const auto seed = tmp("seed_model.h5"), path = tmp("every_operation.h5");
  write_seed_model(seed);
  std::vector<double> big(30000);
  for (size_t i = 0; i < big.size(); ++i)
    big[i] = std::sin(0.1 * i);
  const std::vector<float>          f(big.begin(), big.end());
  const std::vector<long long>      ll(1000, 7);
  const std::vector<int>            in(1000, 3);
  const std::vector<unsigned short> us(1000, 2);
  expect_every_failure_point_is_an_io_error(path, [&] {
    h5::Writer w(path);
    w.attribute("/", "format", std::string("test"));
    w.attribute("/", "format", std::string("test, replaced"));
    w.attribute("/", "number", 1.5);
    w.attribute("/", "count", 3LL);
    w.create_group("/g");
    w.write("/g/big", {big.size()}, big.data());
    w.write("/g/float", {f.size()}, f.data());
    w.write("/g/ll", {ll.size()}, ll.data());
    w.write("/g/int", {in.size()}, in.data());
    w.write("/g/ushort", {us.size()}, us.data());
    for (const bool raw : {false, true})
      {
        const std::string name = raw ? "/rows_raw" : "/rows";
        w.create_dataset(name, {30, 1000}, true, 3, raw); // 24 kB chunks
        for (hsize_t row = 0; row < 30; row += 3)
          w.write_rows(name, row, 3, big.data() + row * 1000);
      }
    w.flush();
    const h5::Reader source(seed);
    w.copy_root_attributes(source, {"format"});
    for (const char *g : {"/outputs", "/inputs", "/surface", "/modes", "/impulse_response"})
      w.copy_from(source, g);
    w.commit();
  });
}

TEST(Writers, CompressFailsCleanlyAtEveryPointTheDiskCanFill)
{
  const auto model = tmp("seed_model.h5"), path = tmp("compressed.h5");
  write_seed_model(model);
  CompressionOptions o;
  o.theta   = 0.5;
  o.blend   = 2;
  o.threads = 1;
  const RepresentativeModel c = compress(load_model(model), o);
  expect_every_failure_point_is_an_io_error(path,
                                            [&] { save_representative_model(c, model, path); });
  // The copy of the source's groups went through the checked reads: the model loads.
  EXPECT_EQ(load_representative_model(path).n_outputs, c.n_outputs);
}

TEST(Writers, CsvAndTextFailCleanlyAtEveryPointTheDiskCanFill)
{
  std::vector<double> column(20000);
  for (size_t i = 0; i < column.size(); ++i)
    column[i] = 1.0 / (1 + i);
  const auto csv = tmp("table.csv"), text = tmp("report.md");
  expect_every_failure_point_is_an_io_error(csv, [&] { write_csv(csv, {"a"}, {column}); });
  expect_every_failure_point_is_an_io_error(
    text, [&] { write_text_file(text, std::string(100000, 'x')); });
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

// Every report states when and from which commit it was made (irdm_common/report_stamp.h), as
// git itself names the source tree's commit.
TEST(Writers, ReportStampNamesTheSourceTreesCommit)
{
  const std::string stamp = report_stamp();
  std::string       head;
  if (FILE *p = ::popen("git -C '" IRDM_MESH_DIR "/..' rev-parse --short=7 HEAD 2>/dev/null", "r"))
    {
      char line[64] = {};
      if (std::fgets(line, sizeof line, p))
        head = std::string(line).substr(0, 7);
      ::pclose(p);
    }
  if (head.empty())
    EXPECT_NE(stamp.find("an unknown commit"), std::string::npos) << stamp;
  else
    EXPECT_NE(stamp.find("at commit " + head), std::string::npos) << stamp << " vs " << head;
  EXPECT_EQ(stamp.rfind("Made on 20", 0), 0u) << stamp;
  EXPECT_NE(stamp.find(" UTC at "), std::string::npos) << stamp;
  EXPECT_NE(stamp.find("(irdm " IRDM_VERSION ")."), std::string::npos) << stamp;
}
