// Writes a CSV whole rows at a time, so that the file is never cut inside a row: rows are
// gathered in a buffer and handed to write(2) only as complete rows, every write and the
// final close are checked, and errors name the file (a full disk, /dev/full, a closed
// pipe's EPIPE). "-" is standard output.
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "private_folder.hpp"

namespace spacearm {

// A failed write or close. Not a runtime_error: an integrator passes it on unchanged
// instead of reporting it as a failed step.
class OutputError : public std::exception {
 public:
  explicit OutputError(std::string what) : what_(std::move(what)) {}
  const char* what() const noexcept override { return what_.c_str(); }

 private:
  std::string what_;
};

class RowWriter {
 public:
  // `option` names the path in errors (-o, --torque-file).
  explicit RowWriter(const std::string& path, const std::string& option = "-o")
      : path_(path == "-" || path.empty() ? "standard output" : path) {
    if (path == "-" || path.empty()) {
      fd_ = 1;
      owned_ = false;
    } else {
      // Written in place, never renamed over: a FIFO, /dev/null or /dev/stdout is written
      // through, a regular file truncated only once it is known to be one, and a block
      // device (a disk) refused.
      fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOCTTY, 0666);
      if (fd_ < 0)
        throw OutputError(option + ": cannot open '" + path +
                          "' for writing: " + std::strerror(errno));
      struct stat st {};
      if (::fstat(fd_, &st) != 0 || S_ISBLK(st.st_mode)) {
        ::close(fd_);
        fd_ = -1;
        throw OutputError(option + ": '" + path +
                          "' is a block device: a CSV is not written onto a disk");
      }
      if (S_ISREG(st.st_mode) && ::ftruncate(fd_, 0) != 0) {
        const std::string why = std::strerror(errno);
        ::close(fd_);
        fd_ = -1;
        throw OutputError(option + ": cannot truncate '" + path + "': " + why);
      }
    }
  }
  ~RowWriter() {
    if (owned_ && fd_ >= 0) ::close(fd_);
  }
  RowWriter(const RowWriter&) = delete;
  RowWriter& operator=(const RowWriter&) = delete;

  // `row` must end with '\n'; it is written whole when the buffer passes 64 KB or on flush.
  void row(const std::string& row) {
    buffer_ += row;
    bytes_ += row.size();
    if (buffer_.size() >= (1u << 16)) flush();
  }

  void flush() {
    size_t done = 0;
    while (done < buffer_.size()) {
      const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const std::string why = n < 0 ? std::strerror(errno) : "nothing written";
        // A partial write may end inside a row: cut a regular file back to its last whole row.
        const size_t whole = done == 0 ? 0 : buffer_.rfind('\n', done - 1) + 1;
        if (whole <= done && ::ftruncate(fd_, static_cast<off_t>(written_ + whole)) == 0)
          written_ += whole;
        buffer_.clear();
        throw OutputError("writing " + where() + " failed: " + why);
      }
      done += static_cast<size_t>(n);
    }
    written_ += done;
    buffer_.clear();
  }

  // Flushes and closes, checking both (a network file system reports some errors only here).
  void close() {
    flush();
    if (!owned_) return;
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0)
      throw OutputError("closing " + where() + " failed: " + std::strerror(errno));
  }

  std::string where() const { return path_ == "standard output" ? path_ : "'" + path_ + "'"; }
  unsigned long long bytes() const { return bytes_; }

 private:
  std::string path_;
  int fd_ = -1;
  bool owned_ = true;
  std::string buffer_;
  unsigned long long bytes_ = 0, written_ = 0;
};

// A whole output file (a page, a model) replaces `output` through a temporary renamed into place:
// a failed write leaves the old file or none, never half of one, and a link planted at the name
// is not written through. Errors name -o.
inline void replace_output_file(const std::string& output, const std::string& text) {
  try {
    replace_file(output, text, 0644);
  } catch (const FolderError& e) {
    throw std::invalid_argument(std::string("-o: ") + e.what());
  }
}

// -o naming an input file (the scene, a torque file) would overwrite it: refused before the
// output is opened. `inputs` are (what the file is, its path) pairs; empty paths are skipped.
inline void refuse_input_as_output(const std::string& output,
                                   const std::vector<std::pair<std::string, std::string>>& inputs,
                                   const std::string& option = "-o") {
  struct stat out {};
  if (output.empty() || output == "-" || ::stat(output.c_str(), &out) != 0) return;
  for (const auto& [what, path] : inputs) {
    struct stat in {};
    if (!path.empty() && ::stat(path.c_str(), &in) == 0 && in.st_dev == out.st_dev &&
        in.st_ino == out.st_ino)
      throw std::invalid_argument(option + " '" + output + "' is " + what +
                                  " file: it would be overwritten");
  }
}

}  // namespace spacearm
