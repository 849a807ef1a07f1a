#include "model_cache.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>

namespace spacearm {

std::string sha256_hex(const std::string& bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &length, EVP_sha256(), nullptr) != 1)
    throw CompileError("SHA-256 failed (libcrypto)");
  return hex_text(md, length);
}

namespace {

std::string errno_text() { return std::strerror(errno); }

constexpr const char* kCacheTag = "CACHEDIR.TAG";

// The cache's own checks throw CompileError, as every other failure of a load does.
template <class F>
auto as_compile_error(F&& f) -> decltype(f()) {
  return folder_errors_as<CompileError>("", std::forward<F>(f));
}

}  // namespace

CacheFolder::CacheFolder(const std::string& given) : path_(given) {
  while (path_.size() > 1 && path_.back() == '/') path_.pop_back();
  fd_ = as_compile_error([&] {
    return open_private_folder(path_, "cache folder", true,
                               "remove it or choose another cache folder (--cache-dir)");
  });
  // A new, empty folder becomes a cache (the tag marks it for backup tools and for
  // remove_stale_work); best effort, as a read-only cache writes nothing.
  if (list_folder(fd_.get()).empty()) {
    try {
      write_new_file_at(fd_.get(), kCacheTag,
                        "Signature: 8a477f597d28d172789f06886806bc55\n"
                        "# spacearm's compile-and-load cache: see https://bford.info/cachedir/\n",
                        path_ + "/" + kCacheTag);
    } catch (const FolderError&) {
    }
  }
}

Fd CacheFolder::open_library(const std::string& entry, std::string& problem) const {
  return as_compile_error([&] {
    const std::string shown = path_ + "/" + entry;
    const Fd dir = open_private_at(fd_.get(), entry, true, shown, "cache entry");
    if (!dir.valid()) {
      problem = "absent";
      return Fd();
    }
    const Fd marker =
        open_private_at(dir.get(), "COMPLETE", false, shown + "/COMPLETE", "cache file");
    Fd library =
        open_private_at(dir.get(), "libmodel.so", false, shown + "/libmodel.so", "cache file");
    if (!marker.valid() || !library.valid()) {
      problem = "incomplete (no COMPLETE marker or no library)";
      return Fd();
    }
    // The marker's first line is the library's SHA-256; the bytes hashed are those of the
    // open file that will be loaded, so swapping the file after the check changes nothing.
    const std::string expected =
        "sha256 " + sha256_hex(read_all(library.get(), shown + "/libmodel.so")) + "\n";
    if (read_all(marker.get(), shown + "/COMPLETE", 1 << 16).rfind(expected, 0) != 0) {
      problem = "corrupted (library does not match its SHA-256)";
      return Fd();
    }
    return library;
  });
}

std::vector<std::string> CacheFolder::entries_starting_with(const std::string& prefix) const {
  std::vector<std::string> out;
  for (const auto& name : list_folder(fd_.get()))
    if (name.rfind(prefix, 0) == 0) out.push_back(name);
  return out;
}

void CacheFolder::discard(const std::string& entry) const {
  const std::string trash = as_compile_error([] { return unique_name(".trash-"); });
  if (::renameat(fd_.get(), entry.c_str(), fd_.get(), trash.c_str()) != 0) return;  // gone
  remove_tree_at(fd_.get(), trash);
}

WorkFolder CacheFolder::make_work_folder(const std::string& entry) const {
  return as_compile_error([&] {
    WorkFolder work;
    work.name = make_temp_folder_at(fd_.get(), ".tmp-" + entry + "-", path_);
    work.fd =
        Fd(::openat(fd_.get(), work.name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
    // Locked while this process builds in it; remove_stale_work leaves locked folders alone.
    if (!work.fd.valid() || ::flock(work.fd.get(), LOCK_EX | LOCK_NB) != 0) {
      const std::string why = errno_text();
      remove_tree_at(fd_.get(), work.name);
      throw CompileError("cannot prepare a work folder in '" + path_ + "': " + why);
    }
    return work;
  });
}

bool CacheFolder::install(const WorkFolder& work, const std::string& entry) const {
  if (::renameat(fd_.get(), work.name.c_str(), fd_.get(), entry.c_str()) == 0) return true;
  const int error = errno;
  remove(work);
  if (error == EEXIST || error == ENOTEMPTY) return false;  // another process won the race
  throw CompileError("cannot install cache entry '" + path_ + "/" + entry +
                     "': " + std::strerror(error));
}

std::string CacheFolder::keep_failed(const WorkFolder& work, const std::string& entry) const {
  return as_compile_error([&] {
    if (::mkdirat(fd_.get(), "failed", 0700) != 0 && errno != EEXIST)
      throw CompileError("cannot create '" + path_ + "/failed': " + errno_text());
    const Fd failed = open_private_at(fd_.get(), "failed", true, path_ + "/failed", "cache folder");
    if (!failed.valid()) return path_ + "/" + work.name;
    remove_tree_at(failed.get(), entry);
    if (::renameat(fd_.get(), work.name.c_str(), failed.get(), entry.c_str()) != 0)
      return path_ + "/" + work.name;
    return path_ + "/failed/" + entry;
  });
}

void CacheFolder::remove(const WorkFolder& work) const { remove_tree_at(fd_.get(), work.name); }

// A work folder is stale when no process holds its lock. A folder just made and not yet
// locked (the moment between mkdirat and flock) is young: only those untouched for a minute go.
// Only in a folder spacearm made its cache (CACHEDIR.TAG): --cache-dir ~ must not remove a
// .tmp-thesis of yours.
void CacheFolder::remove_stale_work() const {
  if (::faccessat(fd_.get(), kCacheTag, F_OK, AT_SYMLINK_NOFOLLOW) != 0) return;
  const time_t now = std::time(nullptr);
  for (const auto& name : list_folder(fd_.get())) {
    if (name.rfind(".tmp-", 0) != 0 && name.rfind(".trash-", 0) != 0) continue;
    struct stat st;
    if (::fstatat(fd_.get(), name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
    if (now - st.st_mtime < 60) continue;
    if (S_ISDIR(st.st_mode)) {
      const Fd dir(
          ::openat(fd_.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
      if (!dir.valid() || ::flock(dir.get(), LOCK_EX | LOCK_NB) != 0) continue;  // in use
    }
    remove_tree_at(fd_.get(), name);
  }
}

Fd memory_file(const char* name) {
  Fd fd(::memfd_create(name, MFD_CLOEXEC));
  if (!fd.valid())
    throw CompileError(std::string("cannot create a log in memory: ") + errno_text());
  return fd;
}

namespace {
volatile sig_atomic_t g_signal = 0;
void note_signal(int sig) { g_signal = sig; }
void kill_own_group(int) { ::kill(0, SIGKILL); }

// The child of spawn(): a watcher that leads the compiler's process group. It starts the
// compiler, waits for it and exits as it did; if this process dies (even by SIGKILL, through
// PR_SET_PDEATHSIG) or the group is told to stop, it kills the whole group, so that no
// compiler or assembler the driver started is left running. Only async-signal-safe calls:
// the parent may have threads.
[[noreturn]] void watch(char* const* args, pid_t parent, int work_dir, int log, int error_pipe) {
  ::setpgid(0, 0);
  struct sigaction stop {};
  stop.sa_handler = kill_own_group;
  sigemptyset(&stop.sa_mask);
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) ::sigaction(sig, &stop, nullptr);
  ::signal(SIGCHLD, SIG_DFL);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  if (::getppid() != parent) kill_own_group(0);  // the parent died before prctl
  const pid_t compiler = ::fork();
  if (compiler == 0) {
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) ::signal(sig, SIG_DFL);
    ::umask(077);  // what it writes is private whatever the caller's umask (002 is common)
    int error = 0;
    if (::fchdir(work_dir) != 0 || ::dup2(log, 1) < 0 || ::dup2(log, 2) < 0) {
      error = errno;
    } else {
      ::execvp(args[0], args);
      error = errno;
    }
    (void)!::write(error_pipe, &error, sizeof error);  // the parent names why it did not start
    ::_exit(127);
  }
  if (compiler < 0) {
    const int error = errno;
    (void)!::write(error_pipe, &error, sizeof error);
    ::_exit(127);
  }
  ::close(error_pipe);
  int status = 0;
  while (::waitpid(compiler, &status, 0) < 0)
    if (errno != EINTR) ::_exit(127);
  if (WIFEXITED(status)) ::_exit(WEXITSTATUS(status));
  ::signal(WTERMSIG(status), SIG_DFL);
  ::kill(::getpid(), WTERMSIG(status));
  ::_exit(128 + WTERMSIG(status));
}
}  // namespace

std::vector<RunResult> run_all_interruptible(const std::vector<std::vector<std::string>>& argvs,
                                             int work_dir, const std::vector<int>& logs,
                                             const std::function<void()>& on_interrupt,
                                             bool own_signals, int max_running,
                                             const std::function<void(size_t)>& on_success) {
  if (logs.size() != argvs.size()) throw std::logic_error("run_all_interruptible: one log each");
  const size_t n = argvs.size();
  std::vector<RunResult> results(n);
  // Our handlers while the compilers run: a signal stops them instead of leaving them orphaned.
  // A signal the caller ignores (a background job's SIGINT) stays ignored.
  struct sigaction ours {
  }, old_int{}, old_term{};
  ours.sa_handler = note_signal;
  sigemptyset(&ours.sa_mask);
  if (own_signals) g_signal = 0;
  const auto signalled = [own_signals] { return own_signals ? int(g_signal) : 0; };
  sigaction(SIGINT, nullptr, &old_int);
  sigaction(SIGTERM, nullptr, &old_term);
  if (own_signals && old_int.sa_handler != SIG_IGN) sigaction(SIGINT, &ours, nullptr);
  if (own_signals && old_term.sa_handler != SIG_IGN) sigaction(SIGTERM, &ours, nullptr);
  // Each program under its own watcher, in its own process group; at most max_running at once,
  // started in order as earlier ones end.
  const pid_t parent = ::getpid();
  std::vector<pid_t> pids(n, -1);
  std::vector<Fd> error_ins(n);
  std::vector<int> status(n, 0);
  std::vector<bool> done(n, false);
  const size_t limit = max_running > 0 ? static_cast<size_t>(max_running) : n;
  size_t started = 0, running = 0;
  const auto start = [&](size_t k) {
    std::vector<char*> args;
    for (const auto& a : argvs[k]) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int pipe_fds[2];
    if (::pipe2(pipe_fds, O_CLOEXEC | O_NONBLOCK) != 0) {
      results[k].start_error = errno;
      done[k] = true;
      return;
    }
    error_ins[k] = Fd(pipe_fds[0]);
    Fd error_out(pipe_fds[1]);
    // The watcher starts with the stopping signals blocked: one sent to its group before it has
    // its own handlers stays pending (it would otherwise run ours, inherited, and be lost).
    sigset_t stopping, before;
    sigemptyset(&stopping);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&stopping, sig);
    ::pthread_sigmask(SIG_BLOCK, &stopping, &before);
    pids[k] = ::fork();
    if (pids[k] == 0) watch(args.data(), parent, work_dir, logs[k], error_out.get());
    ::pthread_sigmask(SIG_SETMASK, &before, nullptr);
    if (pids[k] > 0) ::setpgid(pids[k], pids[k]);  // also here: no window where a signal misses
    if (pids[k] < 0) results[k].start_error = errno;
    done[k] = pids[k] <= 0;
    running += !done[k];
  };
  // Wait for all; on a signal SIGTERM to every group, SIGKILL if one is still there 5 s later.
  bool one_failed = false;
  for (int waited_after_signal = 0;;) {
    // The next programs start while none failed and no signal came; the others never run.
    for (; started < n && running < limit; ++started) {
      if (one_failed || signalled()) {
        results[started].stopped = !signalled();
        done[started] = true;
        continue;
      }
      start(started);
      one_failed = one_failed || results[started].start_error != 0;
    }
    bool all_done = started == n;
    for (size_t k = 0; k < started; ++k) {
      if (done[k]) continue;
      const pid_t r = ::waitpid(pids[k], &status[k], WNOHANG);
      if (r == pids[k] || (r < 0 && errno != EINTR)) {
        done[k] = true;
        --running;
        // (waitpid's ECHILD, SIGCHLD ignored by the caller, leaves status 0: as before, the
        // files it should have written tell.)
        const bool ok = WIFEXITED(status[k]) && WEXITSTATUS(status[k]) == 0;
        one_failed = one_failed || !ok;
        if (ok && on_success && !signalled()) on_success(k);
      }
      all_done = all_done && done[k];
    }
    if (all_done) break;
    // One failed: the others' work is of no use; stop them (SIGTERM, their watchers pass it on).
    if (one_failed && !signalled())
      for (size_t k = 0; k < started; ++k)
        if (!done[k] && !results[k].stopped) {
          ::kill(-pids[k], SIGTERM);
          results[k].stopped = true;
        }
    if (signalled()) {
      ++waited_after_signal;
      for (size_t k = 0; k < started; ++k)
        if (!done[k]) ::kill(-pids[k], waited_after_signal > 250 ? SIGKILL : SIGTERM);
    }
    const timespec pause{0, 20 * 1000 * 1000};
    ::nanosleep(&pause, nullptr);
  }
  for (size_t k = 0; k < n; ++k) {
    int error = 0;
    if (pids[k] > 0 &&
        ::read(error_ins[k].get(), &error, sizeof error) == static_cast<ssize_t>(sizeof error))
      results[k].start_error = error;
  }
  if (own_signals) {
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
  }
  if (own_signals && g_signal) {
    const int sig = g_signal;
    if (on_interrupt) on_interrupt();
    ::raise(sig);
    for (auto& r : results) r.interrupted = true;  // a handler of the caller's took the signal
    return results;
  }
  for (size_t k = 0; k < n; ++k) {
    if (pids[k] < 0 || results[k].start_error != 0) continue;
    results[k].status = WIFEXITED(status[k])
                            ? WEXITSTATUS(status[k])
                            : 128 + (WIFSIGNALED(status[k]) ? WTERMSIG(status[k]) : 0);
  }
  return results;
}

RunResult run_interruptible(const std::vector<std::string>& argv, int work_dir, int log,
                            const std::function<void()>& on_interrupt) {
  return run_all_interruptible({argv}, work_dir, {log}, on_interrupt)[0];
}

}  // namespace spacearm
