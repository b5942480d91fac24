// The checked reads: every attribute and dataset of every file this project reads passes one
// of them. Nothing is copied out of the file before its type class (for strings: fixed or
// variable length, size, padding, character set) and its dataspace (kind, rank, extent) are
// what the reader expects; anything else is an InputError naming the file and the field.
#include "h5_internal.h"

#include <irdm_common/error.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace irdm::h5
{
  namespace detail
  {
    namespace
    {
      // A string attribute longer than this is not one of ours (the longest, a scene's JSON
      // text, is a few kB).
      constexpr std::size_t max_string_bytes = std::size_t(1) << 24;

      std::string
      attribute_where(const std::string &path, const std::string &object,
                      const std::string &name)
      {
        return "attribute '" + name + "' on '" + object + "' in '" + path + "'";
      }

      std::string
      dataset_where(const std::string &path, const std::string &name)
      {
        return "dataset '" + name + "' in '" + path + "'";
      }

      std::string
      type_name(const hid_t type)
      {
        const std::string bits = std::to_string(8 * H5Tget_size(type)) + "-bit ";
        switch (H5Tget_class(type))
          {
            case H5T_INTEGER:
              return "a " + bits + "integer";
            case H5T_FLOAT:
              return "a " + bits + "float";
            case H5T_STRING:
              return H5Tis_variable_str(type) > 0
                       ? std::string("a variable-length string")
                       : "a fixed-length string of " + std::to_string(H5Tget_size(type)) +
                           " bytes";
            case H5T_COMPOUND:
              return "a compound";
            case H5T_ENUM:
              return "an enum";
            case H5T_OPAQUE:
              return "opaque data";
            case H5T_REFERENCE:
              return "a reference";
            case H5T_BITFIELD:
              return "a bitfield";
            case H5T_TIME:
              return "a time";
            case H5T_VLEN:
              return "a variable-length sequence";
            case H5T_ARRAY:
              return "an array type";
            default:
              return "of an unknown type";
          }
      }

      // Empty if type is a number this program converts as written: a whole number of 1, 2, 4
      // or 8 bytes with every bit used, or an IEEE float of 4 or 8 bytes, either byte order.
      std::string
      numeric_type_problem(const hid_t type)
      {
        const H5T_class_t klass = H5Tget_class(type);
        const std::size_t size  = H5Tget_size(type);
        bool              ok    = false;
        if (klass == H5T_INTEGER)
          {
            const H5T_sign_t  sign  = H5Tget_sign(type);
            const H5T_order_t order = H5Tget_order(type);
            ok = (size == 1 || size == 2 || size == 4 || size == 8) &&
                 H5Tget_precision(type) == 8 * size && H5Tget_offset(type) == 0 &&
                 (sign == H5T_SGN_NONE || sign == H5T_SGN_2) &&
                 (order == H5T_ORDER_LE || order == H5T_ORDER_BE);
          }
        else if (klass == H5T_FLOAT)
          for (const hid_t ieee :
               {H5T_IEEE_F32LE, H5T_IEEE_F32BE, H5T_IEEE_F64LE, H5T_IEEE_F64BE})
            ok = ok || H5Tequal(type, ieee) > 0;
        if (ok)
          return "";
        return "is " + type_name(type) +
               ", not a number (an integer of 1, 2, 4 or 8 bytes or an IEEE float of 4 or 8)";
      }

      std::string
      string_type_problem(const hid_t type)
      {
        if (H5Tget_class(type) != H5T_STRING)
          return "is " + type_name(type) + ", not a string";
        const H5T_cset_t cset = H5Tget_cset(type);
        if (cset != H5T_CSET_ASCII && cset != H5T_CSET_UTF8)
          return "is a string in an unknown character set";
        const H5T_str_t pad = H5Tget_strpad(type);
        if (pad != H5T_STR_NULLTERM && pad != H5T_STR_NULLPAD && pad != H5T_STR_SPACEPAD)
          return "is a string with an unknown padding";
        const htri_t variable = H5Tis_variable_str(type);
        if (variable < 0)
          return "is a string of unknown kind";
        const std::size_t size = H5Tget_size(type);
        if (!variable && (size == 0 || size > max_string_bytes))
          return "is a fixed-length string of " + std::to_string(size) + " bytes (at most " +
                 std::to_string(max_string_bytes) + ")";
        return "";
      }

      std::string
      shape_text(const hid_t space)
      {
        const int            rank = H5Sget_simple_extent_ndims(space);
        std::vector<hsize_t> dims(rank > 0 ? rank : 0);
        if (rank > 0)
          H5Sget_simple_extent_dims(space, dims.data(), nullptr);
        return dims_to_string(dims);
      }

      // Empty if space holds exactly one value: scalar, or a simple space of one element.
      std::string
      one_value_problem(const hid_t space)
      {
        switch (H5Sget_simple_extent_type(space))
          {
            case H5S_SCALAR:
              return "";
            case H5S_NULL:
              return "holds no value (a null dataspace); expected one";
            case H5S_SIMPLE: {
              const hssize_t n = H5Sget_simple_extent_npoints(space);
              if (n == 1)
                return "";
              return "is an array of shape " + shape_text(space) + "; expected one value";
            }
            default:
              return "has an unknown dataspace";
          }
      }

      // An attribute opened with its type and dataspace, all released on scope exit.
      struct OpenAttribute
      {
        Handle      object, attribute, type, space;
        std::string where;
      };

      OpenAttribute
      open_attribute(const hid_t file, const std::string &path, const std::string &object,
                     const std::string &name)
      {
        OpenAttribute a;
        a.where = attribute_where(path, object, name);
        if (object != "/" && !exists(file, path, object))
          throw InputError("'" + path + "' has no object '" + object + "'");
        a.object = Handle(H5Oopen(file, object.c_str(), H5P_DEFAULT), H5Oclose);
        if (!a.object.ok() || H5Aexists(a.object, name.c_str()) <= 0)
          throw InputError("'" + path + "' has no attribute '" + name + "' on '" + object + "'");
        a.attribute = Handle(H5Aopen(a.object, name.c_str(), H5P_DEFAULT), H5Aclose);
        if (a.attribute.ok())
          {
            a.type  = Handle(H5Aget_type(a.attribute), H5Tclose);
            a.space = Handle(H5Aget_space(a.attribute), H5Sclose);
          }
        if (!a.type.ok() || !a.space.ok())
          throw InputError(a.where + " cannot be opened (a damaged file)");
        return a;
      }

      std::string
      read_one_string(const OpenAttribute &a)
      {
        std::string problem = string_type_problem(a.type);
        if (problem.empty())
          problem = one_value_problem(a.space);
        if (!problem.empty())
          throw InputError(a.where + " " + problem);
        const Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
        bool ok = mem.ok() && H5Tset_cset(mem, H5Tget_cset(a.type)) >= 0;
        std::string value;
        if (H5Tis_variable_str(a.type) > 0)
          {
            char *text = nullptr; // one value: one pointer, allocated by HDF5
            ok = ok && H5Tset_size(mem, H5T_VARIABLE) >= 0 && H5Aread(a.attribute, mem, &text) >= 0;
            if (ok && text)
              value = text;
            if (text)
              H5free_memory(text);
          }
        else
          {
            value.assign(H5Tget_size(a.type), '\0');
            // Read as NUL-padded, else the last character would make room for a NUL.
            ok = ok && H5Tset_size(mem, value.size()) >= 0 &&
                 H5Tset_strpad(mem, H5T_STR_NULLPAD) >= 0 &&
                 H5Aread(a.attribute, mem, value.data()) >= 0;
            value.resize(std::min(value.size(), value.find('\0')));
            if (H5Tget_strpad(a.type) == H5T_STR_SPACEPAD)
              value.erase(value.find_last_not_of(' ') + 1);
          }
        if (!ok)
          throw InputError(a.where + " cannot be read (a damaged file)");
        return value;
      }

      template <typename T>
      T
      read_one_number(const OpenAttribute &a, const hid_t mem_type)
      {
        std::string problem = numeric_type_problem(a.type);
        if (problem.empty())
          problem = one_value_problem(a.space);
        if (!problem.empty())
          throw InputError(a.where + " " + problem);
        T value{};
        if (H5Aread(a.attribute, mem_type, &value) < 0)
          throw InputError(a.where + " cannot be read (a damaged file)");
        return value;
      }

      // An open dataset checked to be a numeric array stored in this file: its dataspace
      // simple, its type a plain number, its data neither virtual nor external.
      struct OpenDataset
      {
        Handle               set, type, plist;
        std::vector<hsize_t> dims;
        std::string          where;
      };

      OpenDataset
      open_numeric_dataset(const hid_t file, const std::string &path, const std::string &name)
      {
        OpenDataset d;
        d.dims  = dataset_shape(file, path, name);
        d.where = dataset_where(path, name);
        d.set   = Handle(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
        if (d.set.ok())
          {
            d.type  = Handle(H5Dget_type(d.set), H5Tclose);
            d.plist = Handle(H5Dget_create_plist(d.set), H5Pclose);
          }
        if (!d.type.ok() || !d.plist.ok())
          throw InputError(d.where + " cannot be opened (a damaged file)");
        const std::string problem = numeric_type_problem(d.type);
        if (!problem.empty())
          throw InputError(d.where + " " + problem);
        const H5D_layout_t layout = H5Pget_layout(d.plist);
        if (layout != H5D_COMPACT && layout != H5D_CONTIGUOUS && layout != H5D_CHUNKED)
          throw InputError(d.where + " is not stored in the file itself (a virtual dataset)");
        if (H5Pget_external_count(d.plist) != 0)
          throw InputError(d.where + " keeps its data in an external file");
        return d;
      }
    } // namespace

    void
    silence_hdf5()
    {
      // A file whose close failed (disk full) stays in HDF5's tables, and HDF5 1.10's at-exit
      // cleanup then crashes closing it again (seen under AddressSanitizer: SEGV in
      // H5F__close_cb). Every file of ours is closed by RAII before exit, so that cleanup has
      // nothing to do: turn it off (it must precede the library's initialisation).
      static const bool no_atexit = (H5dont_atexit(), true);
      (void)no_atexit;
      H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    }

    std::string
    dims_to_string(const std::vector<hsize_t> &dims)
    {
      std::ostringstream s;
      s << '(';
      for (std::size_t i = 0; i < dims.size(); ++i)
        s << (i ? ", " : "") << dims[i];
      s << ')';
      return s.str();
    }

    bool
    exists(const hid_t file, const std::string &path, const std::string &name)
    {
      // Walk the path, so that a missing group on the way is no HDF5 error, and so that no
      // link leads out of the file.
      std::string        partial;
      std::istringstream parts(name);
      for (std::string part; std::getline(parts, part, '/');)
        {
          if (part.empty())
            continue;
          partial += "/" + part;
          if (H5Lexists(file, partial.c_str(), H5P_DEFAULT) <= 0)
            return false;
          H5L_info_t info;
          if (H5Lget_info(file, partial.c_str(), &info, H5P_DEFAULT) < 0)
            return false;
          if (info.type != H5L_TYPE_HARD)
            throw InputError("'" + partial + "' in '" + path +
                             "' is a soft or external link; a model keeps its objects in the "
                             "file itself");
        }
      return true;
    }

    std::vector<hsize_t>
    dataset_shape(const hid_t file, const std::string &path, const std::string &name)
    {
      if (!exists(file, path, name))
        throw InputError("'" + path + "' has no dataset '" + name + "'");
      const std::string where = dataset_where(path, name);
      H5O_info_t        info;
      if (H5Oget_info_by_name2(file, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 ||
          info.type != H5O_TYPE_DATASET)
        throw InputError("'" + name + "' in '" + path + "' is not a dataset");
      const Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
      const Handle space(set.ok() ? H5Dget_space(set) : -1, H5Sclose);
      if (!space.ok())
        throw InputError(where + " cannot be opened (a damaged file)");
      const H5S_class_t kind = H5Sget_simple_extent_type(space);
      if (kind != H5S_SIMPLE)
        throw InputError(where + (kind == H5S_SCALAR ? " is a single value (a scalar dataspace)"
                                  : kind == H5S_NULL ? " holds no values (a null dataspace)"
                                                     : " has an unknown dataspace") +
                         "; expected an array");
      const int            rank = H5Sget_simple_extent_ndims(space);
      std::vector<hsize_t> dims(rank > 0 ? rank : 0);
      if (rank < 1 || H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0)
        throw InputError(where + " has no simple shape");
      return dims;
    }

    template <typename T>
    std::vector<T>
    read_numeric_dataset(const hid_t file, const std::string &path, const std::string &name,
                         const std::vector<hsize_t> &expected, const hid_t mem_type)
    {
      const OpenDataset d = open_numeric_dataset(file, path, name);
      if (d.dims != expected)
        throw InputError(d.where + " has shape " + dims_to_string(d.dims) + ", expected " +
                         dims_to_string(expected));
      double n = 1;
      for (const auto x : d.dims)
        n *= static_cast<double>(x);
      // The file must really hold every element (unless filtered): a header claiming a huge
      // extent over a few bytes is refused before any memory is taken.
      const double on_disk = n * static_cast<double>(H5Tget_size(d.type));
      const double stored  = static_cast<double>(H5Dget_storage_size(d.set));
      if (H5Pget_nfilters(d.plist) == 0 && n > 0 && stored < on_disk)
        throw InputError(d.where + " is incomplete: the file holds " +
                         std::to_string(static_cast<long long>(stored)) + " of its " +
                         std::to_string(static_cast<long long>(on_disk)) + " bytes");
      if (n * sizeof(T) > 1e12)
        throw InputError(d.where + " is larger than any model this program reads");
      std::vector<T> data(static_cast<std::size_t>(n));
      if (!data.empty() &&
          H5Dread(d.set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) < 0)
        throw InputError("cannot read " + d.where + " (a damaged file)");
      return data;
    }

    template std::vector<double>
    read_numeric_dataset<double>(hid_t, const std::string &, const std::string &,
                                 const std::vector<hsize_t> &, hid_t);
    template std::vector<float>
    read_numeric_dataset<float>(hid_t, const std::string &, const std::string &,
                                const std::vector<hsize_t> &, hid_t);
    template std::vector<long long>
    read_numeric_dataset<long long>(hid_t, const std::string &, const std::string &,
                                    const std::vector<hsize_t> &, hid_t);

    bool
    has_attribute(const hid_t file, const std::string &path, const std::string &object,
                  const std::string &name)
    {
      if (object != "/" && !exists(file, path, object))
        return false;
      const Handle obj(H5Oopen(file, object.c_str(), H5P_DEFAULT), H5Oclose);
      return obj.ok() && H5Aexists(obj, name.c_str()) > 0;
    }

    std::string
    read_string_attribute(const hid_t file, const std::string &path, const std::string &object,
                          const std::string &name)
    {
      return read_one_string(open_attribute(file, path, object, name));
    }
  } // namespace detail

  using namespace detail;

  Reader::Reader(const std::string &path)
    : path_(path)
  {
    silence_hdf5();
    if (FILE *f = std::fopen(path.c_str(), "rb"))
      std::fclose(f);
    else
      throw InputError("cannot open '" + path + "': no such file or not readable");
    file_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (file_ < 0)
      throw InputError("'" + path + "' is not an HDF5 file (or it is being written by another "
                       "run)");
  }

  Reader::~Reader()
  {
    if (file_ >= 0)
      H5Fclose(file_);
  }

  bool
  Reader::exists(const std::string &name) const
  {
    return detail::exists(file_, path_, name);
  }

  bool
  Reader::is_group(const std::string &name) const
  {
    H5O_info_t info;
    return (name == "/" || exists(name)) &&
           H5Oget_info_by_name2(file_, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) >= 0 &&
           info.type == H5O_TYPE_GROUP;
  }

  std::vector<std::string>
  Reader::members(const std::string &group) const
  {
    if (!is_group(group))
      throw InputError("'" + group + "' in '" + path_ + "' is not a group");
    const Handle g(H5Gopen2(file_, group.c_str(), H5P_DEFAULT), H5Gclose);
    H5G_info_t   info;
    if (!g.ok() || H5Gget_info(g, &info) < 0)
      throw InputError("group '" + group + "' in '" + path_ + "' cannot be read");
    std::vector<std::string> names;
    for (hsize_t i = 0; i < info.nlinks; ++i)
      {
        const ssize_t n = H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0,
                                             H5P_DEFAULT);
        std::string name(n > 0 ? static_cast<std::size_t>(n) : 0, '\0');
        if (n <= 0 || H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(),
                                         name.size() + 1, H5P_DEFAULT) < 0)
          throw InputError("group '" + group + "' in '" + path_ + "' has an unreadable member");
        names.push_back(name);
      }
    return names;
  }

  std::vector<hsize_t>
  Reader::shape(const std::string &name) const
  {
    return dataset_shape(file_, path_, name);
  }

  std::vector<double>
  Reader::read_double(const std::string &name, const std::vector<hsize_t> &expected_dims) const
  {
    return read_numeric_dataset<double>(file_, path_, name, expected_dims, H5T_NATIVE_DOUBLE);
  }

  std::vector<long long>
  Reader::read_int(const std::string &name, const std::vector<hsize_t> &expected_dims) const
  {
    return read_numeric_dataset<long long>(file_, path_, name, expected_dims, H5T_NATIVE_LLONG);
  }

  std::vector<float>
  Reader::read_float(const std::string &name, const std::vector<hsize_t> &expected_dims) const
  {
    return read_numeric_dataset<float>(file_, path_, name, expected_dims, H5T_NATIVE_FLOAT);
  }

  NumberKind
  Reader::number_kind(const std::string &name) const
  {
    const OpenDataset d = open_numeric_dataset(file_, path_, name);
    if (H5Tget_class(d.type) == H5T_INTEGER)
      return NumberKind::integer;
    return H5Tget_size(d.type) == 8 ? NumberKind::double_precision : NumberKind::single_precision;
  }

  bool
  Reader::is_double(const std::string &name) const
  {
    return number_kind(name) == NumberKind::double_precision;
  }

  bool
  Reader::has_attribute(const std::string &object, const std::string &name) const
  {
    return detail::has_attribute(file_, path_, object, name);
  }

  std::vector<std::string>
  Reader::attribute_names(const std::string &object) const
  {
    if (object != "/" && !exists(object))
      throw InputError("'" + path_ + "' has no object '" + object + "'");
    const Handle obj(H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose);
    H5O_info_t   info;
    if (!obj.ok() || H5Oget_info2(obj, &info, H5O_INFO_NUM_ATTRS) < 0)
      throw InputError("the attributes of '" + object + "' in '" + path_ + "' cannot be read");
    std::vector<std::string> names;
    for (hsize_t i = 0; i < info.num_attrs; ++i)
      {
        const ssize_t n = H5Aget_name_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr,
                                             0, H5P_DEFAULT);
        std::string name(n > 0 ? static_cast<std::size_t>(n) : 0, '\0');
        if (n <= 0 || H5Aget_name_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(),
                                         name.size() + 1, H5P_DEFAULT) < 0)
          throw InputError("an attribute of '" + object + "' in '" + path_ +
                           "' has no readable name");
        names.push_back(name);
      }
    return names;
  }

  std::string
  Reader::string_attribute(const std::string &object, const std::string &name) const
  {
    return read_string_attribute(file_, path_, object, name);
  }

  double
  Reader::double_attribute(const std::string &object, const std::string &name) const
  {
    return read_one_number<double>(open_attribute(file_, path_, object, name),
                                   H5T_NATIVE_DOUBLE);
  }

  AttributeValue
  Reader::attribute(const std::string &object, const std::string &name) const
  {
    const OpenAttribute a = open_attribute(file_, path_, object, name);
    AttributeValue      v;
    switch (H5Tget_class(a.type))
      {
        case H5T_STRING:
          v.kind = AttributeValue::Kind::text;
          v.text = read_one_string(a);
          break;
        case H5T_INTEGER:
          v.kind  = AttributeValue::Kind::whole;
          v.whole = read_one_number<long long>(a, H5T_NATIVE_LLONG);
          break;
        default: // a float, or refused by the number's checks
          v.kind = AttributeValue::Kind::real;
          v.real = read_one_number<double>(a, H5T_NATIVE_DOUBLE);
      }
    return v;
  }

  long long
  Reader::count_attribute(const std::string &object, const std::string &name, const long long lo,
                          const long long hi) const
  {
    const double v = double_attribute(object, name);
    if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) || v != std::floor(v))
      throw InputError(attribute_where(path_, object, name) + " is " + std::to_string(v) +
                       "; it must be a whole number in [" + std::to_string(lo) + ", " +
                       std::to_string(hi) + "]");
    return static_cast<long long>(v);
  }
} // namespace irdm::h5
