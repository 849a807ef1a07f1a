// A folder of the current user's, opened once and then used only through its descriptor: the
// compile-and-load cache and a sweep's results folder. Every component of the path is checked
// on the way (links included): another user who could rename, replace or write any of them
// could make spacearm write, compile or load through a path of theirs, so such a path is
// refused. Every later step works relative to the open folder (openat, mkdirat, renameat,
// linkat), never through the path again. POSIX (Linux) only.
#pragma once

#include <sys/stat.h>
#include <sys/types.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace spacearm {

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

// What the checks throw; `what` starts with the folder's role and path.
class FolderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Opens `path` as a private folder. Every folder on the way must belong to root or to you and be
// writable by no one else unless sticky (like /tmp); every link on the way must belong to root
// or to you (its target is then checked the same way); the folder itself must be yours (or
// root's) and writable by no one else. Missing folders are created (mode 0700) when `create`.
// `role` names the folder in messages ("cache folder", "sweep folder -o"); `remedy` says what to
// do.
Fd open_private_folder(const std::string& path, const std::string& role, bool create,
                       const std::string& remedy);

// Refuses what another user could have written: neither yours nor root's, or writable by group
// or others. `shown` and `role` name it in the message, `remedy` says what to do.
void check_private(const struct stat& st, const std::string& shown, const std::string& role,
                   const std::string& remedy);

// Opens `name` inside `dir` without following a link, checks that it is a folder or a regular
// file as asked and that it is private (check_private). Invalid Fd if it does not exist; throws
// FolderError naming `shown` if it is a link, a pipe or someone else's. O_NONBLOCK, so that a
// FIFO planted in its place cannot block.
Fd open_private_at(int dir, const std::string& name, bool folder, const std::string& shown,
                   const std::string& role);

// The whole content of an open regular file, at most `limit` bytes (a longer one is an error
// naming `shown`).
std::string read_all(int fd, const std::string& shown, size_t limit = size_t(1) << 30);

// Opens a regular file of at most `limit` bytes for reading (O_NONBLOCK), checked on the open
// descriptor: a FIFO or a device put in its place cannot block. Errors name `what` and the path.
Fd open_regular_file(const std::string& path, const std::string& what, size_t limit);

// A regular file of at most `limit` bytes, checked on the open descriptor (O_NONBLOCK): a FIFO
// or a device put in its place cannot block or fill memory. Errors name `what` and the path.
std::string read_regular_file(const std::string& path, const std::string& what, size_t limit);

// Creates `name` in `dir` (O_CREAT | O_EXCL | O_NOFOLLOW, so nothing planted there is written
// through) with `text` and `mode`. Throws FolderError naming `shown`.
void write_new_file_at(int dir, const std::string& name, const std::string& text,
                       const std::string& shown, mode_t mode = 0600);

// What kind of file `mode` (st_mode) is, for messages: "a FIFO", "a character device", ...
std::string file_kind(mode_t mode);

// Refuses an existing `name` in `dir` that is not a regular file (a device, a FIFO, a socket, a
// folder or a symbolic link): a rename would replace it (as root, /dev/null itself). Throws
// FolderError naming `shown` and its kind; nothing there, or a regular file, passes.
void refuse_replacing_special_at(int dir, const std::string& name, const std::string& shown);

// replace_file_at in the folder of `path` (opened once; "." for a bare name).
void replace_file(const std::string& path, const std::string& text, mode_t mode = 0644);

// Writes `text` to a new temporary in `dir` and renames it over `name`: the file is whole or not
// there at all. An existing `name` that is not a regular file is refused, never replaced
// (refuse_replacing_special_at). Throws FolderError naming `shown`.
void replace_file_at(int dir, const std::string& name, const std::string& text,
                     const std::string& shown, mode_t mode = 0644);

// A new private (0700) folder in `dir` named `prefix` + six random characters; returns its name.
std::string make_temp_folder_at(int dir, const std::string& prefix, const std::string& shown);

// A name no other process is using: `prefix` + random characters.
std::string unique_name(const std::string& prefix);

// Lowercase hex of `n` bytes.
std::string hex_text(const unsigned char* bytes, size_t n);

// `n` random bytes (getrandom) in hex; `what` names their use in the error.
std::string random_hex(size_t n, const std::string& what);

// Runs f; a FolderError it throws becomes an Error whose message is `prefix` + the folder's
// (the cache's CompileError, the sweep's StudyError).
template <class Error, class F>
auto folder_errors_as(const std::string& prefix, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const FolderError& e) {
    throw Error(prefix + e.what());
  }
}

// The names in the open folder `dir` (not "." and ".."), sorted; empty if it cannot be listed.
std::vector<std::string> list_folder(int dir);

// Removes `name` in `dir` and all it holds, never following a link (a link is removed, not its
// target). Best effort: what cannot be removed stays.
void remove_tree_at(int dir, const std::string& name);

}  // namespace spacearm
