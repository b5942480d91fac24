#include <irdm_common/error.h>
#include <irdm_common/files.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

namespace irdm
{
  namespace fs = std::filesystem;

  namespace
  {
    std::string
    errno_text()
    {
      return std::strerror(errno);
    }

    std::string
    folder_of(const std::string &path)
    {
      const fs::path p = fs::path(path).parent_path();
      return p.empty() ? std::string(".") : p.string();
    }

    void
    fsync_directory(const std::string &dir)
    {
      const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
      if (fd < 0)
        throw IoError("cannot open folder '" + dir + "' to sync it: " + errno_text());
      const bool ok = ::fsync(fd) == 0;
      const std::string why = ok ? "" : errno_text();
      ::close(fd);
      if (!ok)
        throw IoError("cannot sync folder '" + dir + "': " + why);
    }

    std::string
    human_bytes(const double b)
    {
      char s[32];
      std::snprintf(s, sizeof s, "%.3g GB", b / 1e9);
      return s;
    }
  } // namespace

  void
  fsync_file(const std::string &path)
  {
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0)
      throw IoError("cannot open '" + path + "' to sync it: " + errno_text());
    const bool        ok  = ::fsync(fd) == 0;
    const std::string why = ok ? "" : errno_text();
    const bool        closed = ::close(fd) == 0;
    if (!ok || !closed)
      throw IoError("cannot sync '" + path + "' to disk: " + (ok ? errno_text() : why));
  }

  void
  commit_part_file(const std::string &part, const std::string &final_path)
  {
    try
      {
        fsync_file(part);
        if (std::rename(part.c_str(), final_path.c_str()) != 0)
          throw IoError("cannot rename '" + part + "' to '" + final_path + "': " + errno_text());
      }
    catch (...)
      {
        std::remove(part.c_str());
        throw;
      }
    fsync_directory(folder_of(final_path));
  }

  void
  write_text_file(const std::string &path, const std::string &text)
  {
    const std::string part = path + ".part";
    std::FILE        *f    = std::fopen(part.c_str(), "wb");
    if (!f)
      throw IoError("cannot create '" + part + "': " + errno_text());
    const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    const bool flushed = std::fflush(f) == 0;
    const bool closed  = std::fclose(f) == 0;
    if (!written || !flushed || !closed)
      {
        const std::string why = errno_text();
        std::remove(part.c_str());
        throw IoError("cannot write '" + path + "': " + why);
      }
    commit_part_file(part, path);
  }

  OutputLock::OutputLock(const std::string &path)
    : lock_path_(path + ".lock")
  {
    // Open, lock, then check that the locked file is still the one at the path: a run that
    // released and removed the lock in between would otherwise leave us holding a lock on
    // an unlinked file while a third run locks a new one.
    for (int attempt = 0; attempt < 100; ++attempt)
      {
        const int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0)
          throw InputError("cannot create the lock file '" + lock_path_ + "': " + errno_text());
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0)
          {
            const bool busy = errno == EWOULDBLOCK;
            const std::string why = errno_text();
            ::close(fd);
            if (busy)
              throw InputError("another run is writing '" + path + "' (it holds '" +
                               lock_path_ + "'); wait for it to finish or choose another output");
            throw InputError("cannot lock '" + lock_path_ + "': " + why);
          }
        struct stat held, now;
        if (::fstat(fd, &held) == 0 && ::stat(lock_path_.c_str(), &now) == 0 &&
            held.st_dev == now.st_dev && held.st_ino == now.st_ino)
          {
            fd_ = fd;
            return;
          }
        ::close(fd); // removed under us: try again with the new file
      }
    throw InputError("cannot take the lock '" + lock_path_ + "'");
  }

  void
  OutputLock::release()
  {
    if (fd_ >= 0)
      {
        ::unlink(lock_path_.c_str()); // while still held: nobody can hold this inode after us
        ::close(fd_);
        fd_ = -1;
      }
  }

  OutputLock::~OutputLock()
  {
    release();
  }

  OutputLock::OutputLock(OutputLock &&other) noexcept
    : lock_path_(std::move(other.lock_path_))
    , fd_(other.fd_)
  {
    other.fd_ = -1;
  }

  OutputLock &
  OutputLock::operator=(OutputLock &&other) noexcept
  {
    if (this != &other)
      {
        release();
        lock_path_ = std::move(other.lock_path_);
        fd_        = other.fd_;
        other.fd_  = -1;
      }
    return *this;
  }

  bool
  same_file(const std::string &a, const std::string &b)
  {
    std::error_code ec;
    return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec) && !ec;
  }

  void
  check_output_file(const std::string &option, const std::string &path,
                    const std::vector<std::string> &inputs, const bool make_folder)
  {
    const std::string what = option.empty() ? "output" : option;
    if (path.empty())
      throw InputError(what + ": the output file name is empty");
    std::error_code ec;
    if (fs::is_directory(path, ec))
      throw InputError(what + " '" + path + "' is a folder; give a file name");
    for (const auto &in : inputs)
      if (same_file(path, in) || (!in.empty() && fs::absolute(path, ec) == fs::absolute(in, ec)))
        throw InputError(what + " '" + path + "' is an input of this command; it is never "
                         "overwritten: choose another output name");
    const std::string dir = folder_of(path);
    if (!fs::exists(dir, ec))
      {
        if (!make_folder)
          throw InputError(what + " '" + path + "': the folder '" + dir + "' does not exist");
        fs::create_directories(dir, ec);
        if (ec)
          throw InputError(what + " '" + path + "': cannot create the folder '" + dir +
                           "': " + ec.message());
      }
    if (!fs::is_directory(dir, ec))
      throw InputError(what + " '" + path + "': '" + dir + "' is not a folder");
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
      throw InputError(what + " '" + path + "': the folder '" + dir + "' is not writable");
    if (fs::exists(path, ec) && ::access(path.c_str(), W_OK) != 0)
      throw InputError(what + " '" + path + "' exists and is not writable");
  }

  void
  check_output_folder(const std::string &option, const std::string &path)
  {
    const std::string what = option.empty() ? "output folder" : option;
    if (path.empty())
      throw InputError(what + ": the folder name is empty");
    std::error_code ec;
    if (fs::exists(path, ec) && !fs::is_directory(path, ec))
      throw InputError(what + " '" + path + "' exists and is not a folder");
    fs::create_directories(path, ec);
    if (ec)
      throw InputError(what + ": cannot create '" + path + "': " + ec.message());
    if (::access(path.c_str(), W_OK | X_OK) != 0)
      throw InputError(what + " '" + path + "' is not writable");
  }

  std::uint64_t
  available_memory_bytes()
  {
    std::ifstream in("/proc/meminfo");
    std::string   key;
    std::uint64_t kb = 0;
    std::string   unit;
    while (in >> key >> kb >> unit)
      if (key == "MemAvailable:")
        return kb * 1024;
    return 0;
  }

  std::uint64_t
  available_disk_bytes(const std::string &path)
  {
    fs::path        p = fs::absolute(path);
    std::error_code ec;
    while (!p.empty() && !fs::exists(p, ec))
      p = p.parent_path();
    struct statvfs s;
    if (p.empty() || ::statvfs(p.c_str(), &s) != 0)
      return 0;
    return static_cast<std::uint64_t>(s.f_bavail) * s.f_frsize;
  }

  void
  check_memory_estimate(const std::string &what, const double bytes, const bool allow,
                        const std::string &option)
  {
    const double available = static_cast<double>(available_memory_bytes());
    if (allow || available <= 0 || bytes <= 0.9 * available)
      return;
    throw InputError(what + " needs about " + human_bytes(bytes) + " of memory, but only " +
                     human_bytes(available) + " is available; reduce the job, or pass " + option +
                     " to try anyway");
  }

  void
  check_disk_estimate(const std::string &what, const std::string &path, const double bytes,
                      const bool allow, const std::string &option)
  {
    const double available = static_cast<double>(available_disk_bytes(path));
    if (allow || available <= 0 || bytes <= available)
      return;
    throw InputError(what + " needs about " + human_bytes(bytes) + " of disk at '" + path +
                     "', but only " + human_bytes(available) + " is free; free some space, "
                     "choose another output, or pass " + option + " to try anyway");
  }
} // namespace irdm
