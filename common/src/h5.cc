#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include "h5_internal.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <fcntl.h>
#include <unistd.h>

namespace irdm::h5
{
  using detail::dims_to_string;
  using detail::silence_hdf5;

  namespace
  {
    std::atomic<bool> close_failed{false};
  } // namespace

  bool
  a_close_failed()
  {
    return close_failed.load();
  }

  namespace
  {
    // Objects of 64 KiB or more start on a 4096-byte boundary (a page, and a sector on any
    // disk; at most 6 % of such an object's size is lost to it): the raw chunks of
    // create_dataset(..., raw_chunks) can then be written with O_DIRECT. Smaller chunks go
    // through HDF5. Owned by the caller (H5Pclose).
    hid_t
    writer_access_list()
    {
      const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
      if (fapl >= 0 && H5Pset_alignment(fapl, hsize_t(64) << 10, 4096) < 0)
        {
          H5Pclose(fapl);
          return H5P_DEFAULT;
        }
      return fapl < 0 ? H5P_DEFAULT : fapl;
    }

    // A part file opened for writing with that alignment: made anew, or an existing one
    // reopened (resume). Negative on failure.
    hid_t
    open_part_file(const std::string &path, const bool create)
    {
      const hid_t fapl = writer_access_list();
      const hid_t file = create ? H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl)
                                : H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl);
      if (fapl != H5P_DEFAULT)
        H5Pclose(fapl);
      return file;
    }

    hid_t
    open_object(hid_t file, const std::string &object)
    {
      return H5Oopen(file, object.c_str(), H5P_DEFAULT);
    }
  } // namespace

  Writer::Writer(const std::string &path, const Mode mode, OutputLock lock)
    : path_(path)
    , part_path_(path + ".part")
    // Before touching the part file: it may be another run's.
    , lock_(lock.held() ? std::move(lock) : OutputLock(path))
  {
    silence_hdf5();
    if (mode == Mode::resume)
      if (FILE *f = std::fopen(part_path_.c_str(), "rb"))
        {
          std::fclose(f);
          file_ = open_part_file(part_path_, false);
          if (file_ >= 0)
            {
              resumed_ = true;
              return;
            }
          // Unreadable, and no other run holds the lock: a run killed mid-write. Start over.
          std::remove(part_path_.c_str());
          discarded_part_ = true;
        }
    file_ = open_part_file(part_path_, true);
    if (file_ < 0)
      {
        // Made but not written (its first write failed): the disk. Not made: the folder.
        const bool made = std::remove(part_path_.c_str()) == 0;
        if (made)
          throw IoError("cannot write HDF5 file '" + part_path_ + "' (disk full?)");
        throw InputError("cannot create HDF5 file '" + part_path_ + "'");
      }
  }

  void
  Writer::start_over()
  {
    close_direct();
    if (file_ >= 0 && H5Fclose(file_) < 0)
      close_failed = true;
    std::remove(part_path_.c_str());
    resumed_ = false;
    file_    = open_part_file(part_path_, true);
    if (file_ < 0)
      {
        std::remove(part_path_.c_str());
        throw IoError("cannot create HDF5 file '" + part_path_ + "' (disk full?)");
      }
  }

  Writer::~Writer()
  {
    close_direct();
    if (file_ >= 0)
      {
        if (H5Fclose(file_) < 0)
          close_failed = true;
        if (!keep_partial_)
          std::remove(part_path_.c_str());
      }
  }

  void
  Writer::create_dataset(const std::string &name, const std::vector<hsize_t> &dims,
                         const bool is_double, const hsize_t chunk_rows, const bool raw_chunks)
  {
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    std::vector<hsize_t> chunk = dims;
    chunk[0] = std::max<hsize_t>(1, std::min(chunk_rows, dims[0]));
    bool ok = space >= 0 && plist >= 0 &&
              H5Pset_chunk(plist, static_cast<int>(chunk.size()), chunk.data()) >= 0;
    // Every chunk placed now and never filled: write_rows writes them itself.
    if (raw_chunks)
      ok = ok && H5Pset_alloc_time(plist, H5D_ALLOC_TIME_EARLY) >= 0 &&
           H5Pset_fill_time(plist, H5D_FILL_TIME_NEVER) >= 0;
    const hid_t set = ok ? H5Dcreate2(file_, name.c_str(),
                                      is_double ? H5T_IEEE_F64LE : H5T_IEEE_F32LE, space,
                                      H5P_DEFAULT, plist, H5P_DEFAULT)
                         : -1;
    ok = set >= 0;
    ok = (plist < 0 || H5Pclose(plist) >= 0) && ok;
    ok = (space < 0 || H5Sclose(space) >= 0) && ok;
    ok = (set < 0 || H5Dclose(set) >= 0) && ok;
    if (!ok)
      throw IoError("cannot create dataset '" + name + "' " + dims_to_string(dims) + " in '" +
                    part_path_ + "'");
  }

  namespace
  {
    void
    write_rows_any(hid_t file, const std::string &path, const std::string &name,
                   const hsize_t first, const hsize_t n_rows, hid_t mem_type, const void *data)
    {
      const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
      if (set < 0)
        throw IoError("no dataset '" + name + "' in '" + path + "'");
      const hid_t          space = H5Dget_space(set);
      const int            rank  = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
      bool                 ok    = rank >= 1;
      std::vector<hsize_t> dims(ok ? rank : 1), start(dims.size(), 0), count;
      ok       = ok && H5Sget_simple_extent_dims(space, dims.data(), nullptr) >= 0;
      count    = dims;
      start[0] = first;
      count[0] = n_rows;
      ok       = ok && first + n_rows <= dims[0] &&
           H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, count.data(),
                               nullptr) >= 0;
      if (ok)
        {
          const hid_t mem = H5Screate_simple(rank, count.data(), nullptr);
          ok = mem >= 0 && H5Dwrite(set, mem_type, mem, space, H5P_DEFAULT, data) >= 0;
          ok = (mem < 0 || H5Sclose(mem) >= 0) && ok;
        }
      ok = (space < 0 || H5Sclose(space) >= 0) && ok;
      ok = H5Dclose(set) >= 0 && ok;
      if (!ok)
        throw IoError("cannot write rows " + std::to_string(first) + ".." +
                         std::to_string(first + n_rows) + " of '" + name + "' in '" + path +
                         "'");
    }
  } // namespace

  bool
  Writer::close_direct()
  {
    bool ok = true;
    for (int *fd : {&direct_fd_, &plain_fd_})
      if (*fd >= 0)
        {
          ok  = ::close(*fd) == 0 && ok;
          *fd = -1;
        }
    std::free(bounce_);
    bounce_       = nullptr;
    bounce_size_  = 0;
    direct_state_ = 0;
    return ok;
  }

  namespace
  {
    // pwrite all of [data, data + size) at offset, retrying short writes and EINTR.
    bool
    write_all_at(const int fd, const char *data, std::size_t size, off_t offset)
    {
      while (size > 0)
        {
          const ssize_t w = ::pwrite(fd, data, size, offset);
          if (w < 0 && errno == EINTR)
            continue;
          if (w <= 0)
            return false;
          data += w, size -= static_cast<std::size_t>(w), offset += w;
        }
      return true;
    }
  } // namespace

  // Rows [first, first + n) that are whole chunks of a raw_chunks dataset (chunks of whole
  // rows), written to each chunk's place in the file: the 512-byte sectors with O_DIRECT from
  // an aligned copy, the rest (under a sector) plainly after them. Returns false, having
  // written nothing that HDF5's write would not overwrite, wherever that does not apply.
  bool
  Writer::write_chunks_directly(const std::string &name, const hsize_t first, const hsize_t n,
                                const void *data, const std::size_t element_size)
  {
    if (direct_state_ < 0)
      return false;
    if (direct_state_ == 0)
      {
        direct_fd_ = ::open(part_path_.c_str(), O_WRONLY | O_DIRECT | O_CLOEXEC);
        plain_fd_  = ::open(part_path_.c_str(), O_WRONLY | O_CLOEXEC);
        if (direct_fd_ < 0 || plain_fd_ < 0) // e.g. tmpfs refuses O_DIRECT
          {
            close_direct();
            direct_state_ = -1;
            return false;
          }
        direct_state_ = 1;
      }
    const hid_t set = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    if (set < 0)
      return false;
    const hid_t          space = H5Dget_space(set), plist = H5Dget_create_plist(set);
    const int            rank  = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
    std::vector<hsize_t> dims(rank > 0 ? rank : 1), chunk(dims.size()), at(dims.size(), 0);
    bool ok = rank > 0 && plist >= 0 && H5Sget_simple_extent_dims(space, dims.data(), nullptr) >= 0 &&
              H5Pget_layout(plist) == H5D_CHUNKED &&
              H5Pget_chunk(plist, rank, chunk.data()) == rank && first % chunk[0] == 0 &&
              (n % chunk[0] == 0 || first + n == dims[0]) && first + n <= dims[0];
    for (int d = 1; ok && d < rank; ++d)
      ok = chunk[d] == dims[d]; // a chunk is whole rows: contiguous in memory
    std::size_t row_bytes = element_size;
    for (int d = 1; d < rank; ++d)
      row_bytes *= dims[d];
    // Every chunk's place first: nothing is written unless all have one.
    std::vector<haddr_t> addresses;
    for (hsize_t r = first; ok && r < first + n; r += chunk[0])
      {
        at[0]            = r;
        unsigned filters = 0;
        haddr_t  address = HADDR_UNDEF;
        hsize_t  size    = 0;
        ok = H5Dget_chunk_info_by_coord(set, at.data(), &filters, &address, &size) >= 0 &&
             address != HADDR_UNDEF && address % 512 == 0 && filters == 0 &&
             size == chunk[0] * row_bytes;
        addresses.push_back(address);
      }
    if (plist >= 0)
      H5Pclose(plist);
    if (space >= 0)
      H5Sclose(space);
    H5Dclose(set);
    if (!ok)
      return false;
    const std::size_t chunk_bytes = chunk[0] * row_bytes, sectors = chunk_bytes & ~std::size_t(511);
    if (bounce_size_ < sectors)
      {
        std::free(bounce_);
        bounce_      = nullptr;
        bounce_size_ = 0;
        if (posix_memalign(&bounce_, 4096, sectors) != 0)
          return false;
        bounce_size_ = sectors;
      }
    const char *bytes = static_cast<const char *>(data);
    for (std::size_t i = 0; i < addresses.size(); ++i)
      {
        // The last chunk may hold rows beyond the extent: only the rows given are written.
        const std::size_t rows  = std::min<hsize_t>(chunk[0], first + n - (first + i * chunk[0]));
        const std::size_t size  = rows * row_bytes, whole = size & ~std::size_t(511);
        const char       *from  = bytes + i * chunk_bytes;
        const off_t       where = static_cast<off_t>(addresses[i]);
        std::memcpy(bounce_, from, whole);
        if (!write_all_at(direct_fd_, static_cast<const char *>(bounce_), whole, where))
          {
            if (errno == EINVAL && i == 0) // O_DIRECT opened but refused: HDF5 from now on
              {
                close_direct();
                direct_state_ = -1;
                return false;
              }
            throw IoError("cannot write rows of '" + name + "' to '" + part_path_ + "': " +
                          std::strerror(errno) + " (disk full?)");
          }
        if (!write_all_at(plain_fd_, from + whole, size - whole, where + static_cast<off_t>(whole)))
          throw IoError("cannot write rows of '" + name + "' to '" + part_path_ + "': " +
                        std::strerror(errno) + " (disk full?)");
        direct_bytes_ += size;
      }
    return true;
  }

  void
  Writer::write_rows(const std::string &name, hsize_t first, hsize_t n, const float *data)
  {
    if (!write_chunks_directly(name, first, n, data, sizeof(float)))
      write_rows_any(file_, part_path_, name, first, n, H5T_NATIVE_FLOAT, data);
  }
  void
  Writer::write_rows(const std::string &name, hsize_t first, hsize_t n, const double *data)
  {
    if (!write_chunks_directly(name, first, n, data, sizeof(double)))
      write_rows_any(file_, part_path_, name, first, n, H5T_NATIVE_DOUBLE, data);
  }
  void
  Writer::write_rows(const std::string &name, hsize_t first, hsize_t n, const long long *data)
  {
    write_rows_any(file_, part_path_, name, first, n, H5T_NATIVE_LLONG, data);
  }

  bool
  Writer::exists(const std::string &name) const
  {
    return H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0;
  }

  std::vector<long long>
  Writer::read_int(const std::string &name) const
  {
    const auto dims = detail::dataset_shape(file_, part_path_, name);
    return detail::read_numeric_dataset<long long>(file_, part_path_, name, dims,
                                                   H5T_NATIVE_LLONG);
  }

  std::string
  Writer::string_attribute(const std::string &object, const std::string &name) const
  {
    return detail::has_attribute(file_, part_path_, object, name)
             ? detail::read_string_attribute(file_, part_path_, object, name)
             : std::string();
  }

  void
  Writer::flush()
  {
    if (H5Fflush(file_, H5F_SCOPE_GLOBAL) < 0)
      throw IoError("cannot flush '" + part_path_ + "' (disk full?)");
  }

  void
  Writer::create_group(const std::string &name)
  {
    const hid_t g =
      H5Gcreate2(file_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (g < 0 || H5Gclose(g) < 0)
      throw IoError("cannot create group '" + name + "' in '" + part_path_ + "'");
  }

  namespace
  {
    void
    write_any(hid_t file,
              const std::string &path,
              const std::string &name,
              const std::vector<hsize_t> &dims,
              hid_t file_type,
              hid_t mem_type,
              const void *data)
    {
      const hid_t space = H5Screate_simple(static_cast<int>(dims.size()),
                                           dims.data(),
                                           nullptr);
      const hid_t set = H5Dcreate2(file,
                                   name.c_str(),
                                   file_type,
                                   space,
                                   H5P_DEFAULT,
                                   H5P_DEFAULT,
                                   H5P_DEFAULT);
      bool ok = set >= 0;
      if (ok)
        ok = H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
      ok = (set < 0 || H5Dclose(set) >= 0) && ok;
      ok = (space < 0 || H5Sclose(space) >= 0) && ok;
      if (!ok)
        throw IoError("cannot write dataset '" + name + "' " +
                         dims_to_string(dims) + " to '" + path + "'");
    }
  } // namespace

  void
  Writer::write(const std::string &name,
                const std::vector<hsize_t> &dims,
                const double *data)
  {
    write_any(file_, part_path_, name, dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, data);
  }

  void
  Writer::write(const std::string &name,
                const std::vector<hsize_t> &dims,
                const float *data)
  {
    write_any(file_, part_path_, name, dims, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, data);
  }

  void
  Writer::write(const std::string &name,
                const std::vector<hsize_t> &dims,
                const long long *data)
  {
    write_any(file_, part_path_, name, dims, H5T_STD_I64LE, H5T_NATIVE_LLONG, data);
  }

  void
  Writer::write(const std::string &name, const std::vector<hsize_t> &dims, const int *data)
  {
    write_any(file_, part_path_, name, dims, H5T_STD_I32LE, H5T_NATIVE_INT, data);
  }

  void
  Writer::write(const std::string &name, const std::vector<hsize_t> &dims,
                const unsigned short *data)
  {
    write_any(file_, part_path_, name, dims, H5T_STD_U16LE, H5T_NATIVE_USHORT, data);
  }

  void
  Writer::copy_attributes(const Reader &source, const std::string &object,
                          const std::vector<std::string> &except)
  {
    for (const auto &name : source.attribute_names(object))
      {
        if (std::find(except.begin(), except.end(), name) != except.end())
          continue;
        const AttributeValue v = source.attribute(object, name);
        switch (v.kind)
          {
            case AttributeValue::Kind::text:
              attribute(object, name, v.text);
              break;
            case AttributeValue::Kind::whole:
              attribute(object, name, v.whole);
              break;
            case AttributeValue::Kind::real:
              attribute(object, name, v.real);
          }
      }
  }

  void
  Writer::copy_from(const Reader &source, const std::string &object)
  {
    if (source.is_group(object))
      {
        if (object != "/")
          create_group(object);
        copy_attributes(source, object, {});
        for (const auto &member : source.members(object))
          copy_from(source, (object == "/" ? "" : object) + "/" + member);
        return;
      }
    const auto dims = source.shape(object);
    switch (source.number_kind(object))
      {
        case NumberKind::integer:
          write(object, dims, source.read_int(object, dims).data());
          break;
        case NumberKind::single_precision:
          write(object, dims, source.read_float(object, dims).data());
          break;
        case NumberKind::double_precision:
          write(object, dims, source.read_double(object, dims).data());
      }
    copy_attributes(source, object, {});
  }

  void
  Writer::copy_root_attributes(const Reader &source, const std::vector<std::string> &except)
  {
    copy_attributes(source, "/", except);
  }

  namespace
  {
    void
    write_attribute(hid_t file,
                    const std::string &path,
                    const std::string &object,
                    const std::string &name,
                    hid_t type,
                    const void *value)
    {
      const hid_t obj = open_object(file, object);
      if (obj < 0)
        throw InputError("no object '" + object + "' in '" + path + "'");
      const htri_t there = H5Aexists(obj, name.c_str());
      if (there < 0 || (there > 0 && H5Adelete(obj, name.c_str()) < 0))
        {
          H5Oclose(obj);
          throw IoError("cannot replace attribute '" + name + "' on '" + object + "' in '" +
                        path + "'");
        }
      const hid_t space = H5Screate(H5S_SCALAR);
      const hid_t attr =
        H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
      bool ok = attr >= 0 && H5Awrite(attr, type, value) >= 0;
      ok = (attr < 0 || H5Aclose(attr) >= 0) && ok;
      ok = H5Sclose(space) >= 0 && ok;
      ok = H5Oclose(obj) >= 0 && ok;
      if (!ok)
        throw IoError("cannot write attribute '" + name + "' on '" + object +
                         "' in '" + path + "'");
    }
  } // namespace

  void
  Writer::attribute(const std::string &object,
                    const std::string &name,
                    const std::string &value)
  {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, value.empty() ? 1 : value.size());
    H5Tset_strpad(type, H5T_STR_NULLPAD);
    try
      {
        write_attribute(file_, part_path_, object, name, type, value.c_str());
      }
    catch (...)
      {
        H5Tclose(type);
        throw;
      }
    H5Tclose(type);
  }

  void
  Writer::attribute(const std::string &object,
                    const std::string &name,
                    const double value)
  {
    write_attribute(file_, part_path_, object, name, H5T_NATIVE_DOUBLE, &value);
  }

  void
  Writer::attribute(const std::string &object,
                    const std::string &name,
                    const long long value)
  {
    write_attribute(file_, part_path_, object, name, H5T_NATIVE_LLONG, &value);
  }

  void
  Writer::commit()
  {
    // HDF5 caches data and metadata: a full disk often shows only here, in the flush or the
    // close. Either failing leaves the final name untouched.
    // The direct writes' descriptors close first (their data reach the disk with the fsync
    // of commit_part_file); a failed close is a failed write.
    const bool flushed = close_direct() && H5Fflush(file_, H5F_SCOPE_GLOBAL) >= 0;
    const bool closed  = H5Fclose(file_) >= 0;
    file_              = -1;
    if (!closed)
      close_failed = true;
    if (!flushed || !closed)
      {
        std::remove(part_path_.c_str());
        throw IoError("cannot finish HDF5 file '" + path_ + "': writing '" + part_path_ +
                      "' failed (disk full?); nothing was written under the final name");
      }
    commit_part_file(part_path_, path_); // fsync, rename, fsync the folder
  }
} // namespace irdm::h5
