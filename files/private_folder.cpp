#include "private_folder.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <algorithm>
#include <cstring>
#include <deque>
#include <filesystem>
#include <vector>

namespace spacearm {

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

std::string mode_text(mode_t mode) {
  char text[8];
  std::snprintf(text, sizeof text, "%04o", static_cast<unsigned>(mode & 07777));
  return text;
}

bool trusted_owner(uid_t uid) { return uid == 0 || uid == geteuid(); }

// A folder on the way may be passed through if no one but root and you can rename what it
// holds: owned by one of you, and writable by others only if sticky (then only an entry's
// owner may rename it).
bool passable(const struct stat& st) {
  return trusted_owner(st.st_uid) &&
         (!(st.st_mode & (S_IWGRP | S_IWOTH)) || (st.st_mode & S_ISVTX));
}

// The components of a path, without empty ones and ".".
std::deque<std::string> components(const std::string& path) {
  std::deque<std::string> out;
  for (size_t at = 0; at <= path.size();) {
    size_t end = path.find('/', at);
    if (end == std::string::npos) end = path.size();
    const std::string part = path.substr(at, end - at);
    if (!part.empty() && part != ".") out.push_back(part);
    at = end + 1;
  }
  return out;
}

std::string read_link_at(int dir, const std::string& name, const std::string& shown) {
  std::vector<char> buf(PATH_MAX + 1);
  const ssize_t n = ::readlinkat(dir, name.c_str(), buf.data(), buf.size());
  if (n < 0 || static_cast<size_t>(n) >= buf.size())
    throw FolderError("cannot read the link '" + shown + "': " + errno_text());
  return std::string(buf.data(), static_cast<size_t>(n));
}

Fd open_root() {
  Fd root(::open("/", O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!root.valid()) throw FolderError("cannot open '/': " + errno_text());
  return root;
}

}  // namespace

void check_private(const struct stat& st, const std::string& shown, const std::string& role,
                   const std::string& remedy) {
  // Root's files are trusted as the system's own (a read-only cache in an image).
  if (!trusted_owner(st.st_uid))
    throw FolderError(role + " '" + shown + "' is owned by user " + std::to_string(st.st_uid) +
                      ", not by you (user " + std::to_string(geteuid()) +
                      ") or root: refusing to use it; " + remedy);
  if (st.st_mode & (S_IWGRP | S_IWOTH))
    throw FolderError(role + " '" + shown + "' is writable by others (mode " +
                      mode_text(st.st_mode) + "): refusing to use it; chmod go-w it, or remove it");
}

// Walks the path one component at a time from '/', each opened with O_NOFOLLOW relative to the
// one before and checked on the open descriptor; a link is checked (its owner) and its target
// walked the same way. The descriptor returned is the folder that was checked.
Fd open_private_folder(const std::string& given, const std::string& role, bool create,
                       const std::string& remedy) {
  if (given.empty()) throw FolderError(role + ": empty path");
  auto refuse = [&](const std::string& why) {
    throw FolderError(role + " '" + given + "': " + why);
  };
  std::string path = given;
  if (path[0] != '/') {  // getcwd gives the working folder's physical path, without links
    std::vector<char> cwd(PATH_MAX);
    if (!::getcwd(cwd.data(), cwd.size()))
      refuse("cannot find the working folder: " + errno_text());
    path = std::string(cwd.data()) + "/" + path;
  }
  std::deque<std::string> todo = components(path);
  Fd here = open_root();
  std::string walked;  // the path followed so far, links expanded, for messages
  int links = 0;
  while (!todo.empty()) {
    const std::string part = todo.front();
    todo.pop_front();
    const std::string shown =
        part == ".." ? walked.substr(0, walked.rfind('/')) : walked + "/" + part;
    struct stat st;
    if (::fstatat(here.get(), part.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) {
      if (errno != ENOENT || !create) refuse("'" + shown + "': " + errno_text());
      if (::mkdirat(here.get(), part.c_str(), 0700) != 0 && errno != EEXIST)
        refuse("cannot create '" + shown + "': " + errno_text());
      if (::fstatat(here.get(), part.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0)
        refuse("'" + shown + "': " + errno_text());
    }
    if (S_ISLNK(st.st_mode)) {
      if (!trusted_owner(st.st_uid))
        refuse("the link '" + shown + "' on the way belongs to user " + std::to_string(st.st_uid) +
               ", who could point it elsewhere at any time: " + remedy);
      if (++links > 40) refuse("too many links on the way");
      const std::string target = read_link_at(here.get(), part, shown);
      const std::deque<std::string> parts = components(target);
      todo.insert(todo.begin(), parts.begin(), parts.end());
      if (target[0] == '/') {
        here = open_root();
        walked.clear();
      }
      continue;
    }
    Fd next(::openat(here.get(), part.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
    if (!next.valid())
      refuse("'" + shown + "'" +
             (errno == ENOTDIR ? std::string(" is not a folder")
              : errno == ELOOP ? std::string(" was replaced by a link while it was checked")
                               : ": " + errno_text()));
    if (::fstat(next.get(), &st) != 0) refuse("cannot stat '" + shown + "': " + errno_text());
    if (todo.empty())
      check_private(st, given, role, remedy);
    else if (!passable(st))
      refuse("the folder above it, '" + shown + "', is " +
             (!trusted_owner(st.st_uid) ? "owned by user " + std::to_string(st.st_uid)
                                        : std::string("writable by others and not sticky")) +
             ", so another user could replace what it holds: " + remedy);
    here = std::move(next);
    walked = shown;
  }
  // The path was '/' itself (or only '.' and '..' above it): the root is not a private folder.
  struct stat st;
  if (walked.empty() && ::fstat(here.get(), &st) == 0) check_private(st, given, role, remedy);
  return here;
}

Fd open_private_at(int dir, const std::string& name, bool folder, const std::string& shown,
                   const std::string& role) {
  const int flags =
      O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK | (folder ? O_DIRECTORY : O_NOCTTY);
  Fd fd(::openat(dir, name.c_str(), flags));
  if (!fd.valid()) {
    if (errno == ENOENT) return fd;
    if (errno == ELOOP || errno == ENOTDIR)
      throw FolderError(role + " '" + shown + "' is a symbolic link or not a " +
                        (folder ? "folder" : "file") + ": refusing to follow it; remove it");
    throw FolderError(role + " '" + shown + "': cannot open it: " + errno_text());
  }
  struct stat st;
  if (::fstat(fd.get(), &st) != 0)
    throw FolderError(role + " '" + shown + "': cannot stat it: " + errno_text());
  if (folder ? !S_ISDIR(st.st_mode) : !S_ISREG(st.st_mode))
    throw FolderError(role + " '" + shown + "' is not a regular " + (folder ? "folder" : "file") +
                      " (a pipe, a device or a folder?): remove it");
  check_private(st, shown, role, "remove it");
  return fd;
}

std::string read_all(int fd, const std::string& shown, size_t limit) {
  std::string out;
  char buf[1 << 16];
  for (off_t at = 0;;) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw FolderError("cannot read '" + shown + "': " + errno_text());
    if (n == 0) return out;
    if (out.size() + static_cast<size_t>(n) > limit)
      throw FolderError("'" + shown + "' is larger than " + std::to_string(limit) + " bytes");
    out.append(buf, static_cast<size_t>(n));
    at += n;
  }
}

Fd open_regular_file(const std::string& path, const std::string& what, size_t limit) {
  // O_PATH first: a device is never opened (opening one may act: a watchdog starts, a tape
  // rewinds), then the checked file itself through its descriptor.
  const Fd where(::open(path.c_str(), O_PATH | O_CLOEXEC));
  if (!where.valid())
    throw FolderError(what + ": cannot open '" + path + "' (" + std::strerror(errno) + ")");
  struct stat st;
  if (::fstat(where.get(), &st) != 0 || !S_ISREG(st.st_mode))
    throw FolderError(what + ": '" + path + "' is not a regular file");
  Fd fd(::open(("/proc/self/fd/" + std::to_string(where.get())).c_str(),
               O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC));
  if (!fd.valid())
    throw FolderError(what + ": cannot open '" + path + "' (" + std::strerror(errno) + ")");
  struct stat opened;
  if (::fstat(fd.get(), &opened) != 0 || opened.st_dev != st.st_dev || opened.st_ino != st.st_ino)
    throw FolderError(what + ": '" + path + "' changed while it was opened");
  if (static_cast<std::uintmax_t>(st.st_size) > limit)
    throw FolderError(what + ": '" + path + "' is larger than " + std::to_string(limit >> 20) +
                      " MB");
  return fd;
}

std::string read_regular_file(const std::string& path, const std::string& what, size_t limit) {
  const Fd fd = open_regular_file(path, what, limit);
  // read_all stops at the limit too: a file that grows after the check is refused, not read.
  try {
    return read_all(fd.get(), path, limit);
  } catch (const FolderError& e) {
    throw FolderError(what + ": " + e.what());
  }
}

void write_new_file_at(int dir, const std::string& name, const std::string& text,
                       const std::string& shown, mode_t mode) {
  Fd fd(::openat(dir, name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode));
  if (!fd.valid()) throw FolderError("cannot create '" + shown + "': " + errno_text());
  for (size_t at = 0; at < text.size();) {
    const ssize_t n = ::write(fd.get(), text.data() + at, text.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = errno_text();
      ::unlinkat(dir, name.c_str(), 0);
      throw FolderError("cannot write '" + shown + "': " + why);
    }
    at += static_cast<size_t>(n);
  }
  if (::close(fd.release()) != 0) {  // NFS reports a full disk here
    const std::string why = errno_text();
    ::unlinkat(dir, name.c_str(), 0);
    throw FolderError("cannot write '" + shown + "': " + why);
  }
}

void replace_file(const std::string& path, const std::string& text, mode_t mode) {
  const std::filesystem::path p(path);
  const std::string folder = p.has_parent_path() ? p.parent_path().string() : ".";
  const Fd dir(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!dir.valid())
    throw FolderError("cannot open the folder '" + folder + "' of '" + path + "': " + errno_text());
  replace_file_at(dir.get(), p.filename().string(), text, path, mode);
}

std::string file_kind(mode_t mode) {
  if (S_ISREG(mode)) return "a regular file";
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

void refuse_replacing_special_at(int dir, const std::string& name, const std::string& shown) {
  struct stat st;
  // Not there, or not visible: the rename that follows creates it or says why.
  if (::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0 || S_ISREG(st.st_mode)) return;
  throw FolderError("'" + shown + "' exists and is " + file_kind(st.st_mode) +
                    ", not a regular file: it is not replaced (name a new file, or remove it "
                    "first)");
}

void replace_file_at(int dir, const std::string& name, const std::string& text,
                     const std::string& shown, mode_t mode) {
  refuse_replacing_special_at(dir, name, shown);
  const std::string tmp = unique_name(name + ".tmp-");
  write_new_file_at(dir, tmp, text, shown + " (a temporary)", mode);
  if (::renameat(dir, tmp.c_str(), dir, name.c_str()) != 0) {
    const std::string why = errno_text();
    ::unlinkat(dir, tmp.c_str(), 0);
    throw FolderError("cannot write '" + shown + "': " + why);
  }
}

std::string hex_text(const unsigned char* bytes, size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    out += digits[bytes[i] >> 4];
    out += digits[bytes[i] & 15];
  }
  return out;
}

std::string random_hex(size_t n, const std::string& what) {
  std::vector<unsigned char> bytes(n);
  if (::getrandom(bytes.data(), n, 0) != static_cast<ssize_t>(n))
    throw FolderError("no random bytes for " + what + ": " + errno_text());
  return hex_text(bytes.data(), n);
}

std::string unique_name(const std::string& prefix) {
  return prefix + std::to_string(::getpid()) + "-" + random_hex(8, "a temporary name");
}

std::string make_temp_folder_at(int dir, const std::string& prefix, const std::string& shown) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const std::string name = unique_name(prefix);
    if (::mkdirat(dir, name.c_str(), 0700) == 0) return name;
    if (errno != EEXIST)
      throw FolderError("cannot create a work folder in '" + shown + "': " + errno_text());
  }
  throw FolderError("cannot create a work folder in '" + shown + "': no free name");
}

// A descriptor of its own ("." opened afresh): a dup would share the folder's read offset, so a
// second listing of the same descriptor would find nothing.
std::vector<std::string> list_folder(int dir) {
  std::vector<std::string> names;
  const int own = ::openat(dir, ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  DIR* d = own >= 0 ? ::fdopendir(own) : nullptr;
  if (!d) {
    if (own >= 0) ::close(own);
    return names;
  }
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    if (n != "." && n != "..") names.push_back(n);
  }
  ::closedir(d);
  std::sort(names.begin(), names.end());
  return names;
}

// Hand-written: std::filesystem::remove_all works on paths, which a link swapped in on the way
// would redirect; this one goes down through descriptors and never follows a link.
void remove_tree_at(int dir, const std::string& name) {
  struct stat st;
  if (::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) return;
  if (S_ISDIR(st.st_mode)) {
    const int sub = ::openat(dir, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (sub < 0) return;
    const Fd held(sub);
    struct stat above, inside;  // never into another file system mounted there
    if (::fstat(dir, &above) != 0 || ::fstat(sub, &inside) != 0 || above.st_dev != inside.st_dev)
      return;
    const std::vector<std::string> names = list_folder(sub);
    for (const auto& n : names) remove_tree_at(sub, n);
    ::unlinkat(dir, name.c_str(), AT_REMOVEDIR);
  } else {
    ::unlinkat(dir, name.c_str(), 0);
  }
}

}  // namespace spacearm
