#include "model_cache.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>

namespace spacearm {

namespace fs = std::filesystem;

std::string sha256_hex(const std::string& bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &length, EVP_sha256(), nullptr) != 1)
    throw CompileError("SHA-256 failed (libcrypto)");
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < length; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

Fd::~Fd() {
  if (fd_ >= 0) ::close(fd_);
}
Fd& Fd::operator=(Fd&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.release();
  }
  return *this;
}

namespace {

std::string errno_text() { return std::strerror(errno); }

// Refuses what another user could have written: not ours, or writable by group or others.
void check_owned(const struct stat& st, const std::string& path, const char* what) {
  if (st.st_uid != geteuid())
    throw CompileError(
        std::string(what) + " '" + path + "' is owned by user " + std::to_string(st.st_uid) +
        ", not by you (user " + std::to_string(geteuid()) +
        "): refusing to use it; remove it or choose another cache folder (--cache-dir)");
  if (st.st_mode & (S_IWGRP | S_IWOTH)) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw CompileError(std::string(what) + " '" + path + "' is writable by others (mode " + mode +
                       "): refusing to use it; chmod go-w it, or remove it");
  }
}

// Opens `name` in `dir` without following a link, then checks type and owner on the open
// file. Invalid Fd if it does not exist.
Fd open_checked(int dir, const std::string& name, bool directory, const std::string& shown) {
  const int flags = O_RDONLY | O_NOFOLLOW | O_CLOEXEC | (directory ? O_DIRECTORY : 0);
  Fd fd(::openat(dir, name.c_str(), flags));
  if (!fd.valid()) {
    if (errno == ENOENT) return fd;
    if (errno == ELOOP || errno == ENOTDIR)
      throw CompileError("cache: '" + shown + "' is a symbolic link or not a " +
                         (directory ? "folder" : "file") + ": refusing to follow it; remove it");
    throw CompileError("cache: cannot open '" + shown + "': " + errno_text());
  }
  struct stat st;
  if (::fstat(fd.get(), &st) != 0)
    throw CompileError("cache: cannot stat '" + shown + "': " + errno_text());
  if (directory ? !S_ISDIR(st.st_mode) : !S_ISREG(st.st_mode))
    throw CompileError("cache: '" + shown + "' is not a regular " +
                       (directory ? "folder" : "file"));
  check_owned(st, shown, directory ? "cache entry" : "cache file");
  return fd;
}

std::string read_all(int fd) {
  std::string out;
  char buf[1 << 16];
  for (off_t at = 0;;) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw CompileError("cache: read failed: " + errno_text());
    if (n == 0) return out;
    out.append(buf, static_cast<size_t>(n));
    at += n;
  }
}

// mkdir -p with mode 0700 for every folder it creates.
void create_private_folders(const fs::path& path) {
  fs::path partial;
  for (const auto& part : path) {
    partial /= part;
    if (::mkdir(partial.c_str(), 0700) != 0 && errno != EEXIST)
      throw CompileError("cannot create cache folder '" + partial.string() + "': " + errno_text());
  }
}

long pid_in(const std::string& name, const std::string& prefix) {
  if (name.rfind(prefix, 0) != 0) return -1;
  return std::strtol(name.c_str() + prefix.size(), nullptr, 10);
}

}  // namespace

namespace {

// Every folder above the cache must be safe from renames by others: owned by root or by
// us, and writable by no one else unless sticky (like /tmp, where only an entry's owner
// may rename it). Otherwise another user could swap the cache folder or a work folder
// for a link while spacearm writes into it by path.
void check_ancestors(const std::string& path) {
  char resolved[PATH_MAX];
  if (!::realpath(path.c_str(), resolved))
    throw CompileError("cache folder '" + path + "': " + errno_text());
  for (fs::path p = fs::path(resolved).parent_path();; p = p.parent_path()) {
    struct stat st;
    if (::lstat(p.c_str(), &st) != 0)
      throw CompileError("cache folder '" + path + "': cannot stat " + p.string());
    const bool owner_ok = st.st_uid == 0 || st.st_uid == geteuid();
    const bool others_write = (st.st_mode & (S_IWGRP | S_IWOTH)) && !(st.st_mode & S_ISVTX);
    if (!owner_ok || others_write)
      throw CompileError(
          "cache folder '" + path + "': the folder above it, '" + p.string() + "', is " +
          (!owner_ok ? "owned by user " + std::to_string(st.st_uid)
                     : std::string("writable by others and not sticky")) +
          ", so another user could replace the cache: choose a cache folder inside one of yours");
    if (p == p.root_path()) return;
  }
}

}  // namespace

CacheFolder::CacheFolder(const std::string& given) : path_(given) {
  if (given.empty()) throw CompileError("cache folder: empty path");
  while (path_.size() > 1 && path_.back() == '/') path_.pop_back();  // "link/" would follow a link
  const std::string& path = path_;
  create_private_folders(path);
  check_ancestors(path);
  fd_ = Fd(::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  if (!fd_.valid()) {
    const int error = errno;
    throw CompileError("cache folder '" + path + "': " + std::strerror(error) +
                       (error == ELOOP ? " (a symbolic link: give its target instead)" : ""));
  }
  struct stat st;
  if (::fstat(fd_.get(), &st) != 0)
    throw CompileError("cache folder '" + path + "': " + errno_text());
  check_owned(st, path, "cache folder");
}

Fd CacheFolder::open_library(const std::string& entry, std::string& problem) const {
  const std::string shown = path_ + "/" + entry;
  const Fd dir = open_checked(fd_.get(), entry, true, shown);
  if (!dir.valid()) {
    problem = "absent";
    return Fd();
  }
  const Fd marker = open_checked(dir.get(), "COMPLETE", false, shown + "/COMPLETE");
  Fd library = open_checked(dir.get(), "libmodel.so", false, shown + "/libmodel.so");
  if (!marker.valid() || !library.valid()) {
    problem = "incomplete (no COMPLETE marker or no library)";
    return Fd();
  }
  // The marker's first line is the library's SHA-256; the bytes hashed are those of the
  // open file that will be loaded, so swapping the file after the check changes nothing.
  const std::string expected = "sha256 " + sha256_hex(read_all(library.get())) + "\n";
  if (read_all(marker.get()).rfind(expected, 0) != 0) {
    problem = "corrupted (library does not match its SHA-256)";
    return Fd();
  }
  return library;
}

void CacheFolder::discard(const std::string& entry) const {
  const std::string trash = ".trash-" + std::to_string(getpid()) + "-" + entry;
  if (::renameat(fd_.get(), entry.c_str(), fd_.get(), trash.c_str()) != 0) return;  // already gone
  std::error_code ec;
  fs::remove_all(path_ + "/" + trash, ec);
}

std::string CacheFolder::make_work_folder(const std::string& entry) const {
  std::string name = path_ + "/.tmp-" + std::to_string(getpid()) + "-" + entry + "-XXXXXX";
  if (!::mkdtemp(name.data()))
    throw CompileError("cannot create a work folder in '" + path_ + "': " + errno_text());
  return name;
}

bool CacheFolder::install(const std::string& work, const std::string& entry) const {
  const std::string work_name = fs::path(work).filename().string();
  if (::renameat(fd_.get(), work_name.c_str(), fd_.get(), entry.c_str()) == 0) return true;
  const int error = errno;
  std::error_code ec;
  fs::remove_all(work, ec);
  if (error == EEXIST || error == ENOTEMPTY) return false;  // another process won the race
  throw CompileError("cannot install cache entry '" + path_ + "/" + entry +
                     "': " + std::strerror(error));
}

std::string CacheFolder::keep_failed(const std::string& work, const std::string& entry) const {
  if (::mkdirat(fd_.get(), "failed", 0700) != 0 && errno != EEXIST)
    throw CompileError("cannot create '" + path_ + "/failed': " + errno_text());
  const Fd failed = open_checked(fd_.get(), "failed", true, path_ + "/failed");
  std::error_code ec;
  fs::remove_all(path_ + "/failed/" + entry, ec);
  const std::string work_name = fs::path(work).filename().string();
  if (::renameat(fd_.get(), work_name.c_str(), failed.get(), entry.c_str()) != 0) return work;
  return path_ + "/failed/" + entry;
}

void CacheFolder::remove_stale_work() const {
  DIR* d = ::fdopendir(::dup(fd_.get()));
  if (!d) return;
  std::vector<std::string> stale;
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    long pid = pid_in(name, ".tmp-");
    if (pid < 0) pid = pid_in(name, ".trash-");
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(name);
  }
  ::closedir(d);
  for (const auto& name : stale) {
    std::error_code ec;
    fs::remove_all(path_ + "/" + name, ec);
  }
}

namespace {
volatile sig_atomic_t g_signal = 0;
void note_signal(int sig) { g_signal = sig; }

// fork + exec rather than posix_spawn, for what the child must set up itself: its own
// process group (stopped as a whole on interrupt), default SIGINT/SIGTERM, and death with
// its parent (PR_SET_PDEATHSIG), so that even a SIGKILL of spacearm leaves no compiler
// running. Standard output and error go to `log`. Returns the pid, or -1.
pid_t spawn_in_own_group(const std::vector<char*>& args, const std::string& log) {
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid > 0) ::setpgid(pid, pid);  // also here: no window where a signal misses the group
  if (pid != 0) return pid;
  // Child: only async-signal-safe calls until exec.
  ::setpgid(0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent) ::_exit(127);  // the parent died before prctl
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd < 0 || ::dup2(fd, 1) < 0 || ::dup2(fd, 2) < 0) ::_exit(127);
  ::execvp(args[0], args.data());
  ::_exit(127);
}
}  // namespace

int run_interruptible(const std::vector<std::string>& argv, const std::string& log,
                      const std::function<void()>& on_interrupt) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // Our handlers while the compiler runs: a signal stops it instead of leaving it orphaned.
  // A signal the caller ignores (a background job's SIGINT) stays ignored.
  struct sigaction ours {
  }, old_int{}, old_term{};
  ours.sa_handler = note_signal;
  sigemptyset(&ours.sa_mask);
  g_signal = 0;
  sigaction(SIGINT, nullptr, &old_int);
  sigaction(SIGTERM, nullptr, &old_term);
  if (old_int.sa_handler != SIG_IGN) sigaction(SIGINT, &ours, nullptr);
  if (old_term.sa_handler != SIG_IGN) sigaction(SIGTERM, &ours, nullptr);
  const pid_t pid = spawn_in_own_group(args, log);
  const int spawned = pid > 0 ? 0 : -1;
  int status = -1;
  if (spawned == 0) {
    for (int waited_after_signal = 0;;) {
      const pid_t r = ::waitpid(pid, &status, WNOHANG);
      if (r == pid || (r < 0 && errno != EINTR)) break;
      // SIGTERM to the whole group, SIGKILL if it is still there 5 s later.
      if (g_signal) ::kill(-pid, ++waited_after_signal > 250 ? SIGKILL : SIGTERM);
      const timespec pause{0, 20 * 1000 * 1000};
      ::nanosleep(&pause, nullptr);
    }
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (g_signal) {
    const int sig = g_signal;
    if (on_interrupt) on_interrupt();
    ::raise(sig);
    return -2;  // a handler of the caller's took the signal
  }
  if (spawned != 0 || (WIFEXITED(status) && WEXITSTATUS(status) == 127)) return -1;  // not started
  return WIFEXITED(status) ? WEXITSTATUS(status)
                           : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace spacearm
