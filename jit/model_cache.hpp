// The compile-and-load cache's file system side, written so that nothing in the cache can be
// planted: the folder is opened once through checked components (private_folder.hpp) and
// every later step works relative to it; every entry must belong to you and be writable by no
// one else; nothing inside is reached through a symbolic link; libraries are verified by
// SHA-256 (OpenSSL's libcrypto) on the same open file that is then loaded; entries are
// installed by one atomic rename that never replaces another process's entry; a build in
// progress holds a lock on its work folder, so no other process (another container's
// included, where process ids mean nothing) removes it. POSIX (Linux) only.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "private_folder.hpp"

namespace spacearm {

class CompileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Lowercase hex SHA-256 of `bytes`.
std::string sha256_hex(const std::string& bytes);

// A build's own folder in the cache: private, and locked (flock) by this process while open.
struct WorkFolder {
  std::string name;  // inside the cache folder
  Fd fd;
};

// The cache folder, opened once and checked; entries are reached relative to it.
class CacheFolder {
 public:
  // Creates the folder (mode 0700) if missing; refuses a path that another user could redirect
  // (open_private_folder), naming the path and what to do.
  explicit CacheFolder(const std::string& path);
  const std::string& path() const { return path_; }
  int fd() const { return fd_.get(); }

  // The entry's library, opened and verified against the SHA-256 in its COMPLETE marker.
  // Returns an invalid Fd with `problem` set when the entry is absent or incomplete or its
  // library does not match (a crash or a full disk, repaired by rebuilding); throws
  // CompileError when the entry is unsafe (a link, a pipe, someone else's, writable by others).
  Fd open_library(const std::string& entry, std::string& problem) const;

  // The names of the entries that start with `prefix`, sorted.
  std::vector<std::string> entries_starting_with(const std::string& prefix) const;

  // Moves an incomplete or corrupted entry aside and removes it (never another process's
  // fresh entry: only one that failed verification).
  void discard(const std::string& entry) const;

  // A new private (0700) work folder inside the cache, named after `entry`, locked.
  WorkFolder make_work_folder(const std::string& entry) const;

  // Renames the work folder to `entry` atomically. False if another process installed the
  // entry first (the work folder is then removed and the winner's entry is the one to use).
  bool install(const WorkFolder& work, const std::string& entry) const;

  // Keeps a failed build's work folder as failed/ENTRY for inspection; returns its path.
  std::string keep_failed(const WorkFolder& work, const std::string& entry) const;

  // Removes the folder and what it holds.
  void remove(const WorkFolder& work) const;

  // Removes work and trash folders that no process holds locked (left by a crash or a kill).
  void remove_stale_work() const;

 private:
  std::string path_;
  Fd fd_;
};

// The outcome of running a program.
struct RunResult {
  int status = -1;      // exit status; 128 + signal if killed; -1 if it did not start
  int start_error = 0;  // errno when it did not start (ENOENT: no such program)
  bool interrupted = false;
  bool stopped = false;  // stopped by run_all_interruptible because another program failed
};

// Runs argv[0] with argv (no shell) in the folder `work_dir` (a descriptor), its standard
// output and error into the descriptor `log`, in its own process group, with a watcher that
// kills the whole group if this process dies, even by SIGKILL. SIGINT or SIGTERM received
// meanwhile stops the group, runs `on_interrupt` (to remove temporary files) and re-raises
// the signal (a signal the caller ignores stays ignored); if the caller's own handler
// returns, the result says interrupted.
RunResult run_interruptible(const std::vector<std::string>& argv, int work_dir, int log,
                            const std::function<void()>& on_interrupt);

// The same for several programs at once, each with its own log; a signal stops them all, and
// so does one's failure (the others are then `stopped`).
// own_signals = false (a compile in the background, beside the caller's own handlers): the
// handlers are left alone; the watchers still stop the programs if this process dies.
// max_running > 0: at most that many run at once, started in the order given (a program not
// started because another failed is `stopped` too). on_success(k), on this thread as soon as
// program k has exited with status 0 (the others may still run).
std::vector<RunResult> run_all_interruptible(const std::vector<std::vector<std::string>>& argvs,
                                             int work_dir, const std::vector<int>& logs,
                                             const std::function<void()>& on_interrupt,
                                             bool own_signals = true, int max_running = 0,
                                             const std::function<void(size_t)>& on_success = {});

// An anonymous file in memory (memfd): a compiler's messages survive a full disk.
Fd memory_file(const char* name);

}  // namespace spacearm
