#pragma once
// Internal to irdm_common: what the HDF5 writer and reader share. Not installed.
#include <irdm_common/h5.h>

#include <hdf5.h>

#include <string>
#include <utility>
#include <vector>

namespace irdm::h5::detail
{
  /// An HDF5 identifier closed by its own function when it goes out of scope, so that every
  /// early return and every throw releases what was opened, the last opened first.
  class Handle
  {
  public:
    using Close = herr_t (*)(hid_t);
    Handle() = default;
    Handle(const hid_t id, const Close close)
      : id_(id)
      , close_(close)
    {}
    ~Handle()
    {
      if (id_ >= 0)
        close_(id_);
    }
    Handle(Handle &&other) noexcept
      : id_(std::exchange(other.id_, -1))
      , close_(other.close_)
    {}
    Handle &
    operator=(Handle &&other) noexcept
    {
      std::swap(id_, other.id_);
      std::swap(close_, other.close_);
      return *this;
    }
    Handle(const Handle &) = delete;
    Handle &
    operator=(const Handle &) = delete;

    bool
    ok() const
    {
      return id_ >= 0;
    }
    operator hid_t() const
    {
      return id_;
    }
    /// Closes now; false if the close failed (a writer's last data may not have reached the
    /// file).
    bool
    close()
    {
      const hid_t id = std::exchange(id_, -1);
      return id < 0 || close_(id) >= 0;
    }

  private:
    hid_t id_    = -1;
    Close close_ = nullptr;
  };

  /// Turns off HDF5's own error printing and its at-exit cleanup (see h5.cc).
  void
  silence_hdf5();

  std::string
  dims_to_string(const std::vector<hsize_t> &dims);

  /// The checked reads, on any open file (a Reader's, or a Writer's partial file when it
  /// resumes). `path` names the file in messages. Every one refuses with an InputError naming
  /// the file and the attribute or dataset.
  ///
  /// A whole numeric dataset of the given shape, converted to mem_type (of elem_size bytes).
  void
  read_numeric_dataset(hid_t file, const std::string &path, const std::string &name,
                       const std::vector<hsize_t> &expected, hid_t mem_type,
                       std::size_t elem_size, std::vector<char> &out);
  template <typename T>
  std::vector<T>
  read_numeric_dataset(hid_t file, const std::string &path, const std::string &name,
                       const std::vector<hsize_t> &expected, hid_t mem_type);
  /// The shape of a numeric array dataset (a simple dataspace; scalar and null are refused).
  std::vector<hsize_t>
  dataset_shape(hid_t file, const std::string &path, const std::string &name);
  /// True if object (a hard-linked path, or "/") carries the attribute.
  bool
  has_attribute(hid_t file, const std::string &path, const std::string &object,
                const std::string &name);
  /// One string held by an attribute.
  std::string
  read_string_attribute(hid_t file, const std::string &path, const std::string &object,
                        const std::string &name);
  /// True if the link chain to name exists and is made of hard links (an external or soft
  /// link is refused: a model's objects live in the file itself).
  bool
  exists(hid_t file, const std::string &path, const std::string &name);
} // namespace irdm::h5::detail
