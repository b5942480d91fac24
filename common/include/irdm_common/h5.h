#pragma once
// Thin RAII layer over the HDF5 C API, shared by the FEM output and the IRDM model files.
// Arrays are row-major (C order), as HDF5 stores them. Writers are atomic: data go to
// "<path>.part" and are renamed to <path> only by commit() (flush, close, fsync, rename, fsync
// of the folder, every return checked), so no half-written file ever carries the final name.
// A writer holds an OutputLock on "<path>.lock": a second run to the same path is refused
// before it touches the first one's part file. Write failures are IoError; bad files read
// are InputError.
#include <irdm_common/files.h>

#include <hdf5.h>

#include <string>
#include <vector>

namespace irdm::h5
{
  /// True once an HDF5 file failed to close (disk full). HDF5 keeps such a file in its tables,
  /// and its own cleanup at exit (at MPI_Finalize for parallel HDF5) then crashes closing it
  /// again: a program should end with _Exit once its files are closed (apps/irdm.cc does).
  bool
  a_close_failed();

  /// An HDF5 file being written; becomes visible under its final name on commit().
  class Writer
  {
  public:
    enum class Mode
    {
      create, // always start a new "<path>.part"
      resume  // reopen an existing "<path>.part" (see resumed()), else create
    };
    /// lock: the output's lock if the caller took it earlier (before long work), else taken here.
    explicit Writer(const std::string &path, Mode mode = Mode::create, OutputLock lock = {});
    /// True if an existing partial file was reopened.
    bool
    resumed() const
    {
      return resumed_;
    }
    /// True if a partial file was there but unreadable (a run that failed mid-write) and was
    /// discarded.
    bool
    discarded_unreadable_part() const
    {
      return discarded_part_;
    }
    /// Keep "<path>.part" when destroyed without commit(), for a later resume.
    void
    keep_partial(bool keep)
    {
      keep_partial_ = keep;
    }
    /// A dataset written in blocks of rows (first dimension) by write_rows(), chunked so
    /// that a block of chunk_rows rows is one HDF5 chunk.
    void
    create_dataset(const std::string &name, const std::vector<hsize_t> &dims, bool is_double,
                   hsize_t chunk_rows);
    void
    write_rows(const std::string &name, hsize_t first_row, hsize_t n_rows, const float *data);
    void
    write_rows(const std::string &name, hsize_t first_row, hsize_t n_rows, const double *data);
    void
    write_rows(const std::string &name, hsize_t first_row, hsize_t n_rows,
               const long long *data);
    /// Reading back from a partial file (resume): a whole integer dataset, and a string
    /// attribute ("" if absent).
    std::vector<long long>
    read_int(const std::string &name) const;
    std::string
    string_attribute(const std::string &object, const std::string &name) const;
    bool
    exists(const std::string &name) const;
    /// Discards the partial file (a resumed one from another spec) and starts a new one,
    /// keeping the lock.
    void
    start_over();
    /// Pushes everything written so far to disk.
    void
    flush();
    ~Writer(); // without commit(): the partial file is removed
    Writer(const Writer &) = delete;
    Writer &
    operator=(const Writer &) = delete;

    void
    create_group(const std::string &name);
    void
    write(const std::string &name,
          const std::vector<hsize_t> &dims,
          const double *data);
    void
    write(const std::string &name,
          const std::vector<hsize_t> &dims,
          const float *data);
    void
    write(const std::string &name,
          const std::vector<hsize_t> &dims,
          const long long *data);
    void
    write(const std::string &name, const std::vector<hsize_t> &dims, const int *data);
    void
    write(const std::string &name, const std::vector<hsize_t> &dims,
          const unsigned short *data);
    /// Copies object (a group with everything in it) from another HDF5 file to the same path.
    void
    copy_from(const std::string &source_file, const std::string &object);
    /// Copies every attribute of the source file's root to this file's root, except those
    /// named in `except`.
    void
    copy_root_attributes(const std::string &source_file, const std::vector<std::string> &except);
    /// Attribute on an object ("/" for the file root).
    void
    attribute(const std::string &object,
              const std::string &name,
              const std::string &value);
    void
    attribute(const std::string &object, const std::string &name, double value);
    void
    attribute(const std::string &object,
              const std::string &name,
              long long value);
    void
    commit();

  private:
    std::string path_;
    std::string part_path_;
    hid_t       file_           = -1;
    bool        resumed_        = false;
    bool        discarded_part_ = false;
    bool        keep_partial_   = false;
    OutputLock  lock_;
  };

  /// Read access with shape checks; every failure is an InputError naming file and dataset.
  class Reader
  {
  public:
    explicit Reader(const std::string &path);
    ~Reader();
    Reader(const Reader &) = delete;
    Reader &
    operator=(const Reader &) = delete;

    bool
    exists(const std::string &name) const;
    std::vector<hsize_t>
    shape(const std::string &name) const;
    std::vector<double>
    read_double(const std::string &name,
                const std::vector<hsize_t> &expected_dims) const;
    std::vector<long long>
    read_int(const std::string &name,
             const std::vector<hsize_t> &expected_dims) const;
    std::vector<float>
    read_float(const std::string &name, const std::vector<hsize_t> &expected_dims) const;
    /// True if the dataset is stored as 8-byte floating point.
    bool
    is_double(const std::string &name) const;
    bool
    has_attribute(const std::string &object, const std::string &name) const;
    std::string
    string_attribute(const std::string &object, const std::string &name) const;
    /// A single number (an array attribute is refused, never read into one double).
    double
    double_attribute(const std::string &object, const std::string &name) const;
    /// A single whole number in [lo, hi]; InputError naming the attribute otherwise.
    long long
    count_attribute(const std::string &object, const std::string &name, long long lo,
                    long long hi) const;

  private:
    std::string path_;
    hid_t       file_ = -1;
  };
} // namespace irdm::h5
