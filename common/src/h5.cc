#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

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
    // HDF5 prints its own error stack by default; we report errors ourselves.
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

    hid_t
    open_object(hid_t file, const std::string &object)
    {
      return H5Oopen(file, object.c_str(), H5P_DEFAULT);
    }

    // A fixed-length string attribute that exists on obj ("" if it is not a string).
    std::string
    read_string_attribute(hid_t obj, const std::string &name)
    {
      const hid_t attr  = H5Aopen(obj, name.c_str(), H5P_DEFAULT);
      const hid_t ftype = H5Aget_type(attr);
      std::string value;
      if (H5Tget_class(ftype) == H5T_STRING && !H5Tis_variable_str(ftype))
        {
          value.resize(H5Tget_size(ftype));
          const hid_t mtype = H5Tcopy(H5T_C_S1);
          H5Tset_size(mtype, value.size());
          H5Tset_strpad(mtype, H5T_STR_NULLPAD); // else the last character makes room for a NUL
          H5Aread(attr, mtype, value.data());
          H5Tclose(mtype);
          value.resize(value.find('\0') == std::string::npos ? value.size() : value.find('\0'));
        }
      H5Tclose(ftype);
      H5Aclose(attr);
      return value;
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
      throw InputError("cannot create HDF5 file '" + part_path_ + "'");
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
      throw IoError("cannot create HDF5 file '" + part_path_ + "'");
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
    const hid_t set = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    if (set < 0)
      throw InputError("no dataset '" + name + "' in '" + part_path_ + "'");
    const hid_t space = H5Dget_space(set);
    const hssize_t n  = H5Sget_simple_extent_npoints(space);
    std::vector<long long> out(n > 0 ? n : 0);
    const bool ok = H5Dread(set, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) >= 0;
    H5Sclose(space);
    H5Dclose(set);
    if (!ok)
      throw InputError("cannot read '" + name + "' from '" + part_path_ + "'");
    return out;
  }

  std::string
  Writer::string_attribute(const std::string &object, const std::string &name) const
  {
    const hid_t obj = open_object(file_, object);
    if (obj < 0)
      return "";
    const std::string value =
      H5Aexists(obj, name.c_str()) > 0 ? read_string_attribute(obj, name) : std::string();
    H5Oclose(obj);
    return value;
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
  Writer::copy_from(const std::string &source_file, const std::string &object)
  {
    const hid_t src = H5Fopen(source_file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (src < 0)
      throw InputError("cannot open HDF5 file '" + source_file + "'");
    const bool ok = H5Ocopy(src, object.c_str(), file_, object.c_str(), H5P_DEFAULT,
                            H5P_DEFAULT) >= 0;
    H5Fclose(src); // read-only
    if (!ok)
      throw IoError("cannot copy '" + object + "' from '" + source_file + "' to '" + path_ + "'");
  }

  void
  Writer::copy_root_attributes(const std::string &source_file,
                               const std::vector<std::string> &except)
  {
    const hid_t src = H5Fopen(source_file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (src < 0)
      throw InputError("cannot open HDF5 file '" + source_file + "'");
    const hid_t from = H5Gopen2(src, "/", H5P_DEFAULT), to = H5Gopen2(file_, "/", H5P_DEFAULT);
    H5O_info_t info;
    H5Oget_info2(from, &info, H5O_INFO_NUM_ATTRS);
    bool ok = true;
    for (hsize_t i = 0; i < info.num_attrs && ok; ++i)
      {
        const hid_t attr = H5Aopen_by_idx(from, ".", H5_INDEX_NAME, H5_ITER_INC, i, H5P_DEFAULT,
                                          H5P_DEFAULT);
        std::string name(static_cast<size_t>(H5Aget_name(attr, 0, nullptr)), '\0');
        H5Aget_name(attr, name.size() + 1, name.data());
        if (std::find(except.begin(), except.end(), name) == except.end())
          {
            const hid_t type = H5Aget_type(attr), space = H5Aget_space(attr);
            std::vector<char> buffer(H5Aget_storage_size(attr) + H5Tget_size(type));
            ok = H5Aread(attr, type, buffer.data()) >= 0;
            if (H5Aexists(to, name.c_str()) > 0)
              H5Adelete(to, name.c_str());
            const hid_t copy = H5Acreate2(to, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
            ok = ok && copy >= 0 && H5Awrite(copy, type, buffer.data()) >= 0;
            ok = (copy < 0 || H5Aclose(copy) >= 0) && ok;
            ok = H5Sclose(space) >= 0 && ok;
            ok = H5Tclose(type) >= 0 && ok;
          }
        ok = H5Aclose(attr) >= 0 && ok;
      }
    ok = H5Gclose(from) >= 0 && ok;
    ok = H5Gclose(to) >= 0 && ok;
    H5Fclose(src); // read-only
    if (!ok)
      throw IoError("cannot copy the root attributes of '" + source_file + "' to '" +
                    part_path_ + "'");
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
    // Walk the path so that a missing intermediate group is not an HDF5 error.
    std::string partial;
    std::istringstream parts(name);
    std::string part;
    while (std::getline(parts, part, '/'))
      {
        if (part.empty())
          continue;
        partial += "/" + part;
        if (H5Lexists(file_, partial.c_str(), H5P_DEFAULT) <= 0)
          return false;
      }
    return true;
  }

  std::vector<hsize_t>
  Reader::shape(const std::string &name) const
  {
    if (!exists(name))
      throw InputError("'" + path_ + "' has no dataset '" + name + "'");
    const hid_t set = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    if (set < 0)
      throw InputError("'" + name + "' in '" + path_ + "' is not a dataset");
    const hid_t space = H5Dget_space(set);
    const int   rank  = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
    std::vector<hsize_t> dims(rank > 0 ? rank : 0);
    const bool ok = rank >= 0 && (rank == 0 || H5Sget_simple_extent_dims(space, dims.data(),
                                                                          nullptr) >= 0);
    if (space >= 0)
      H5Sclose(space);
    H5Dclose(set);
    if (!ok)
      throw InputError("dataset '" + name + "' in '" + path_ + "' has no simple shape");
    return dims;
  }

  namespace
  {
    // Reads a whole dataset after checking, against the file itself, that it is what it claims:
    // its shape, a numeric type, and (for datasets stored without filters) that the file
    // really holds all of its elements. Only then is memory allocated.
    template <typename T>
    std::vector<T>
    read_any(hid_t file,
             const Reader &reader,
             const std::string &path,
             const std::string &name,
             const std::vector<hsize_t> &expected,
             hid_t mem_type)
    {
      const auto dims = reader.shape(name);
      if (dims != expected)
        throw InputError("dataset '" + name + "' in '" + path + "' has shape " +
                         dims_to_string(dims) + ", expected " +
                         dims_to_string(expected));
      double n = 1;
      for (const auto d : dims)
        n *= static_cast<double>(d);
      const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
      if (set < 0)
        throw InputError("cannot open dataset '" + name + "' in '" + path + "'");
      const hid_t       type  = H5Dget_type(set);
      const H5T_class_t klass = type >= 0 ? H5Tget_class(type) : H5T_NO_CLASS;
      const double      bytes_on_disk = n * (type >= 0 ? static_cast<double>(H5Tget_size(type)) : 0);
      if (type >= 0)
        H5Tclose(type);
      const hid_t plist    = H5Dget_create_plist(set);
      const int   nfilters = plist >= 0 ? H5Pget_nfilters(plist) : -1;
      if (plist >= 0)
        H5Pclose(plist);
      const double stored = static_cast<double>(H5Dget_storage_size(set));
      std::string  problem;
      if (klass != H5T_INTEGER && klass != H5T_FLOAT)
        problem = "is not numeric";
      else if (nfilters == 0 && n > 0 && stored < bytes_on_disk)
        problem = "is incomplete: the file holds " + std::to_string(static_cast<long long>(stored)) +
                  " of its " + std::to_string(static_cast<long long>(bytes_on_disk)) + " bytes";
      else if (n * sizeof(T) > 1e12)
        problem = "is larger than any model this program reads";
      if (!problem.empty())
        {
          H5Dclose(set);
          throw InputError("dataset '" + name + "' in '" + path + "' " + problem);
        }
      std::vector<T> data(static_cast<std::size_t>(n));
      const bool ok = H5Dread(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) >= 0;
      H5Dclose(set);
      if (!ok)
        throw InputError("cannot read dataset '" + name + "' from '" + path +
                         "' (wrong type or a damaged file)");
      return data;
    }
  } // namespace

  std::vector<double>
  Reader::read_double(const std::string &name,
                      const std::vector<hsize_t> &expected_dims) const
  {
    return read_any<double>(file_, *this, path_, name, expected_dims,
                            H5T_NATIVE_DOUBLE);
  }

  std::vector<long long>
  Reader::read_int(const std::string &name,
                   const std::vector<hsize_t> &expected_dims) const
  {
    return read_any<long long>(file_, *this, path_, name, expected_dims,
                               H5T_NATIVE_LLONG);
  }

  std::vector<float>
  Reader::read_float(const std::string &name, const std::vector<hsize_t> &expected_dims) const
  {
    return read_any<float>(file_, *this, path_, name, expected_dims, H5T_NATIVE_FLOAT);
  }

  bool
  Reader::is_double(const std::string &name) const
  {
    shape(name); // checks existence
    const hid_t set  = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    const hid_t type = H5Dget_type(set);
    const bool  r    = H5Tget_class(type) == H5T_FLOAT && H5Tget_size(type) == 8;
    H5Tclose(type);
    H5Dclose(set);
    return r;
  }

  bool
  Reader::has_attribute(const std::string &object, const std::string &name) const
  {
    if (object != "/" && !exists(object))
      return false;
    const hid_t obj = open_object(file_, object);
    if (obj < 0)
      return false;
    const bool r = H5Aexists(obj, name.c_str()) > 0;
    H5Oclose(obj);
    return r;
  }

  std::string
  Reader::string_attribute(const std::string &object,
                           const std::string &name) const
  {
    if (!has_attribute(object, name))
      throw InputError("'" + path_ + "' has no attribute '" + name + "' on '" + object + "'");
    const hid_t       obj   = open_object(file_, object);
    const std::string value = read_string_attribute(obj, name);
    H5Oclose(obj);
    return value;
  }

  double
  Reader::double_attribute(const std::string &object,
                           const std::string &name) const
  {
    if (!has_attribute(object, name))
      throw InputError("'" + path_ + "' has no attribute '" + name + "' on '" + object + "'");
    const hid_t obj   = open_object(file_, object);
    const hid_t attr  = H5Aopen(obj, name.c_str(), H5P_DEFAULT);
    const hid_t space = attr >= 0 ? H5Aget_space(attr) : -1;
    const hid_t type  = attr >= 0 ? H5Aget_type(attr) : -1;
    // One number, never an array: reading an array into one double would overrun it.
    const bool one = space >= 0 && H5Sget_simple_extent_npoints(space) == 1;
    const H5T_class_t klass = type >= 0 ? H5Tget_class(type) : H5T_NO_CLASS;
    double value = 0;
    const bool ok = one && (klass == H5T_INTEGER || klass == H5T_FLOAT) &&
                    H5Aread(attr, H5T_NATIVE_DOUBLE, &value) >= 0;
    if (type >= 0)
      H5Tclose(type);
    if (space >= 0)
      H5Sclose(space);
    if (attr >= 0)
      H5Aclose(attr);
    H5Oclose(obj);
    if (!ok)
      throw InputError("attribute '" + name + "' on '" + object + "' in '" + path_ +
                       "' is not a single number");
    return value;
  }

  long long
  Reader::count_attribute(const std::string &object, const std::string &name,
                          const long long lo, const long long hi) const
  {
    const double v = double_attribute(object, name);
    if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) || v != std::floor(v))
      throw InputError("attribute '" + name + "' on '" + object + "' in '" + path_ + "' is " +
                       std::to_string(v) + "; it must be a whole number in [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<long long>(v);
  }
} // namespace irdm::h5
