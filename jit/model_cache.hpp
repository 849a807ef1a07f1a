// The compile-and-load cache's file system side, written so that nothing in the cache can be
// planted: the folder and every entry must belong to the current user and be writable by no
// one else; nothing inside is reached through a symbolic link; libraries are verified by
// SHA-256 (OpenSSL's libcrypto) on the same open file that is then loaded; entries are
// installed by one atomic rename that never replaces another process's entry. POSIX only.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace spacearm {

class CompileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Lowercase hex SHA-256 of `bytes`.
std::string sha256_hex(const std::string& bytes);

// An open file descriptor, closed on destruction.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd();
  Fd(Fd&& o) noexcept : fd_(o.release()) {}
  Fd& operator=(Fd&& o) noexcept;
  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

// The cache folder, opened once and checked; entries are reached relative to it.
class CacheFolder {
 public:
  // Creates the folder (mode 0700) if missing; refuses a symbolic link, a folder owned by
  // someone else or writable by group or others, naming the path and what to do.
  explicit CacheFolder(const std::string& path);
  const std::string& path() const { return path_; }

  // The entry's library, opened and verified against the SHA-256 in its COMPLETE marker.
  // Returns an invalid Fd with `problem` set when the entry is absent or incomplete or its
  // library does not match (a crash or a full disk, repaired by rebuilding); throws
  // CompileError when the entry is unsafe (a link, someone else's, writable by others).
  Fd open_library(const std::string& entry, std::string& problem) const;

  // Moves an incomplete or corrupted entry aside and removes it (never another process's
  // fresh entry: only one that failed verification).
  void discard(const std::string& entry) const;

  // A new private (0700) work folder inside the cache, named after `entry` and this process.
  std::string make_work_folder(const std::string& entry) const;

  // Renames the work folder to `entry` atomically. False if another process installed the
  // entry first (the work folder is then removed and the winner's entry is the one to use).
  bool install(const std::string& work, const std::string& entry) const;

  // Keeps a failed build's work folder as failed/ENTRY for inspection; returns its path.
  std::string keep_failed(const std::string& work, const std::string& entry) const;

  // Removes work and trash folders left by processes that no longer run.
  void remove_stale_work() const;

 private:
  std::string path_;
  Fd fd_;
};

// Runs argv[0] with argv (no shell), standard output and error into `log`, in its own
// process group. SIGINT or SIGTERM received meanwhile stops the whole group, runs
// `on_interrupt` (to remove temporary files) and re-raises the signal (a signal the caller
// ignores stays ignored). Returns the exit status (0 on success), -1 if the program could
// not be started, -2 if interrupted and the caller's own handler returned.
int run_interruptible(const std::vector<std::string>& argv, const std::string& log,
                      const std::function<void()>& on_interrupt);

}  // namespace spacearm
