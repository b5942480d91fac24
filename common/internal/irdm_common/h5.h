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

#include <cstddef>
#include <string>
#include <vector>

namespace irdm::h5
{
  /// True once an HDF5 file failed to close (disk full). HDF5 keeps such a file in its tables,
  /// and its own cleanup at exit (at MPI_Finalize for parallel HDF5) then crashes closing it
  /// again: a program should end with _Exit once its files are closed (apps/irdm.cc does).
  bool
  a_close_failed();

  class Reader;

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
    /// that a block of chunk_rows rows is one HDF5 chunk. raw_chunks: every chunk gets its
    /// place in the file now (4096-byte aligned, nothing written), and write_rows() writes
    /// whole chunks there itself with O_DIRECT, past the page cache: on this project's VM a
    /// buffered write costs about 2.5 s of kernel time per GB, a direct one 0.1 s (dd, 4.8 GB:
    /// 12.7 s against 2.8 s). Where the file system refuses O_DIRECT, or for a chunk without a
    /// place (a partial file of an older version), it writes through HDF5 as before.
    void
    create_dataset(const std::string &name, const std::vector<hsize_t> &dims, bool is_double,
                   hsize_t chunk_rows, bool raw_chunks = false);
    /// Bytes write_rows() wrote directly (raw_chunks), past HDF5 and the page cache.
    std::size_t
    bytes_written_directly() const
    {
      return direct_bytes_;
    }
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
    /// Copies object (a group with everything in it, or a dataset) from another file to the
    /// same path, through the source's checked reads: numeric datasets and attributes that
    /// hold one number or one string. Anything else in it is refused (InputError).
    void
    copy_from(const Reader &source, const std::string &object);
    /// Copies every attribute of the source file's root to this file's root, except those
    /// named in `except`, as copy_from does.
    void
    copy_root_attributes(const Reader &source, const std::vector<std::string> &except);
    /// Attribute on an object ("/" for the file root); replaces one of the same name.
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
    // The direct path of write_rows (raw_chunks): the part file opened again with O_DIRECT,
    // and plainly for the last bytes of a chunk that are not a whole 512-byte sector; a
    // bounce buffer aligned for O_DIRECT. direct_state_: 0 not tried, 1 open, -1 refused.
    int         direct_fd_ = -1, plain_fd_ = -1, direct_state_ = 0;
    std::size_t direct_bytes_ = 0;
    void       *bounce_ = nullptr;
    std::size_t bounce_size_ = 0;
    bool
    write_chunks_directly(const std::string &name, hsize_t first, hsize_t n, const void *data,
                          std::size_t element_size);
    bool
    close_direct(); // false if a descriptor failed to close
    void
    copy_attributes(const Reader &source, const std::string &object,
                    const std::vector<std::string> &except);
  };

  /// How a numeric dataset is stored.
  enum class NumberKind
  {
    integer,
    single_precision,
    double_precision
  };

  /// What an attribute holds: one string or one number.
  struct AttributeValue
  {
    enum class Kind
    {
      text,
      whole,
      real
    };
    Kind        kind = Kind::text;
    std::string text;
    long long   whole = 0;
    double      real  = 0;
  };

  /// Read access to a file nobody vouches for. Every attribute and dataset is read through one
  /// checked read of its kind (a number, a string, a numeric array): before anything is
  /// copied, the HDF5 type class (for a string: fixed or variable length, size, padding,
  /// character set) and the dataspace (kind, rank, extent) must be what that read expects,
  /// the data must be stored in the file itself (no external or soft links, no external or
  /// virtual storage); anything else is an InputError naming the file and the field.
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
    bool
    is_group(const std::string &name) const;
    /// The names of a group's members.
    std::vector<std::string>
    members(const std::string &group) const;
    /// The shape of a numeric array dataset.
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
    NumberKind
    number_kind(const std::string &name) const;
    /// True if the dataset is stored as 8-byte floating point.
    bool
    is_double(const std::string &name) const;
    bool
    has_attribute(const std::string &object, const std::string &name) const;
    std::vector<std::string>
    attribute_names(const std::string &object) const;
    /// One string or one number, whichever the attribute holds.
    AttributeValue
    attribute(const std::string &object, const std::string &name) const;
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
