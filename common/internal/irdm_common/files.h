#pragma once
// Safe outputs: every result reaches its final name only complete and on disk.
//   write to "<path>.part" -> check every write -> fsync it -> rename -> fsync the directory.
// Two runs that could write the same output are kept apart by an OutputLock on "<path>.lock".
// No deal.II, no HDF5.
#include <cstdint>
#include <string>
#include <vector>

namespace irdm
{
  /// fsync the file at path; IoError if it cannot be opened or synced.
  void
  fsync_file(const std::string &path);

  /// Renames a finished part file to its final name: fsync(part), rename, fsync(directory).
  /// IoError on any failure; the final name is then untouched (the part file is removed).
  void
  commit_part_file(const std::string &part, const std::string &final_path);

  /// Writes text to path atomically (through "<path>.part", see commit_part_file).
  void
  write_text_file(const std::string &path, const std::string &text);

  /// An exclusive advisory lock (flock) on "<path>.lock", held for the object's life, so that
  /// two runs never write the same output. Refuses at once (InputError naming the lock file)
  /// if another process holds it. The lock file is removed on release.
  class OutputLock
  {
  public:
    OutputLock() = default;
    explicit OutputLock(const std::string &path);
    ~OutputLock();
    OutputLock(OutputLock &&other) noexcept;
    OutputLock &
    operator=(OutputLock &&other) noexcept;
    OutputLock(const OutputLock &) = delete;
    OutputLock &
    operator=(const OutputLock &) = delete;
    bool
    held() const
    {
      return fd_ >= 0;
    }

  private:
    void
    release();
    std::string lock_path_;
    int         fd_ = -1;
  };

  /// Checks before any work that an output file can be written: its folder exists (or can be
  /// made, when make_folder) and is writable, the path is not a folder, and it is none of the
  /// inputs (same file by device and inode). InputError naming the option otherwise.
  void
  check_output_file(const std::string &option, const std::string &path,
                    const std::vector<std::string> &inputs = {}, bool make_folder = false);

  /// The same for an output folder (created if missing).
  void
  check_output_folder(const std::string &option, const std::string &path);

  /// True if a and b name the same existing file.
  bool
  same_file(const std::string &a, const std::string &b);

  /// Bytes of memory the system can still give (MemAvailable), 0 if unknown.
  std::uint64_t
  available_memory_bytes();

  /// Bytes free on the file system holding path (or its nearest existing parent), 0 if unknown.
  std::uint64_t
  available_disk_bytes(const std::string &path);

  /// Refuses (InputError) work whose estimated memory exceeds what is available, unless
  /// allow is set. what names the job, option the override ("--allow-large").
  void
  check_memory_estimate(const std::string &what, double bytes, bool allow,
                        const std::string &option = "--allow-large");
  /// The same for disk space at path.
  void
  check_disk_estimate(const std::string &what, const std::string &path, double bytes, bool allow,
                      const std::string &option = "--allow-large");
} // namespace irdm
