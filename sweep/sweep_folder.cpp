// The results folder of a sweep (sweep.hpp): study.id, one runs-IofN.csv per shard, series/,
// results.csv; and the thread pool that fills it.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "sweep.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace fs = std::filesystem;

namespace {

// The folder's own files must be plain files: a link planted there would make the sweep write
// elsewhere, a pipe would block it. Absent is fine.
void refuse_unless_regular(const fs::path& file) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(file, ec);
  if (!ec && fs::exists(st) && !fs::is_regular_file(st))
    throw StudyError("sweep: '" + file.string() +
                     "' is not a plain file (a link, a pipe or a folder); remove it");
}

std::string read_whole(const fs::path& file) {
  refuse_unless_regular(file);
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

bool failed_row(const std::string& row) {
  return row.compare(row.find(',') + 1, 7, "failed,") == 0;
}

// Adds the rows of one runs-*.csv file by run; a line cut by a kill (no newline) is left out.
// Returns the file's length up to its last complete line.
// first: receives the file's first run (-1 if none).
size_t read_rows(const fs::path& file, const StudyRunner& runner, std::map<long, std::string>& rows,
                 long* first = nullptr) {
  if (first) *first = -1;
  const std::string all = read_whole(file), &header = runner.header();
  auto fail = [&](long line, const std::string& why) {
    throw StudyError("sweep: '" + file.string() + "' line " + std::to_string(line) + ": " + why +
                     "; remove the file to run its rows again");
  };
  if (all.size() < header.size()) return 0;  // cut while its header was written
  if (all.compare(0, header.size(), header) != 0) fail(1, "not the study's header");
  size_t at = header.size();
  for (long line = 2;; ++line) {
    const size_t nl = all.find('\n', at);
    if (nl == std::string::npos) break;
    std::string row = all.substr(at, nl + 1 - at);
    long run = -1;
    if (const std::string why = runner.row_problem(row, &run); !why.empty())
      fail(line, "not a row of this study: " + why);
    if (first && *first < 0) *first = run;
    const auto [it, added] = rows.emplace(run, row);
    if (!added && it->second != row)
      fail(line, "run " + std::to_string(run) +
                     " has another row already (here or in another "
                     "runs-*.csv file)");
    at = nl + 1;
  }
  return at;
}

std::vector<fs::path> row_files(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("runs-", 0) == 0 && e.path().extension() == ".csv") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The rows of every shard's file in the folder, by run.
std::map<long, std::string> folder_rows(const fs::path& dir, const StudyRunner& runner) {
  std::map<long, std::string> rows;
  for (const auto& f : row_files(dir)) read_rows(f, runner, rows);
  return rows;
}

// The folder belongs to one study: study.id names it, and a different study is refused.
void claim_folder(const fs::path& dir, const StudyRunner& runner) {
  const Study& s = runner.study();
  const std::string id = "spacearm sweep\nstudy " + s.identity + "\nruns " +
                         std::to_string(s.num_runs()) + "\n" + runner.header();
  const fs::path file = dir / "study.id";
  refuse_unless_regular(file);
  // Created whole or not at all: shards started together on a new folder each write a
  // temporary and link it into place; all but one find it there and compare.
  const fs::path tmp = dir / ("study.id.tmp-" + std::to_string(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << id;
    if (!out.flush()) throw StudyError("sweep: cannot write '" + tmp.string() + "'");
  }
  const bool created = ::link(tmp.c_str(), file.c_str()) == 0;
  fs::remove(tmp);
  if (!created) {
    if (read_whole(file) != id)
      throw StudyError("sweep: -o '" + dir.string() +
                       "' holds the results of another study (or of this one before an edit; "
                       "see its study.id): give another folder, or remove it to start over");
  }
}

// The shard's own row file: locked against a second sweep, cut after its last whole row.
int open_shard_file(const fs::path& file, size_t complete) {
  refuse_unless_regular(file);
  const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
  if (fd < 0)
    throw StudyError("sweep: cannot open '" + file.string() + "': " + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    throw StudyError("sweep: another sweep is writing '" + file.string() +
                     "' (the same shard twice at once?)");
  }
  if (::ftruncate(fd, static_cast<off_t>(complete)) != 0 || ::lseek(fd, 0, SEEK_END) < 0) {
    ::close(fd);
    throw StudyError("sweep: cannot prepare '" + file.string() + "': " + std::strerror(errno));
  }
  return fd;
}

// Whole rows with one write each (no stdio buffer): a kill loses at most the row being written.
void write_all(int fd, const std::string& text, const fs::path& file) {
  for (size_t at = 0; at < text.size();) {
    const ssize_t n = ::write(fd, text.data() + at, text.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw StudyError("sweep: cannot write '" + file.string() + "': " + std::strerror(errno));
    at += static_cast<size_t>(n);
  }
}

// A file written whole or not at all: a temporary beside it, renamed over it.
void write_whole(const fs::path& file, const std::string& text) {
  const fs::path tmp = file.string() + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    if (!out.flush()) throw StudyError("sweep: cannot write '" + tmp.string() + "'");
  }
  fs::rename(tmp, file);
}

std::string duration_text(double seconds) {
  char buf[32];
  if (seconds < 90)
    std::snprintf(buf, sizeof buf, "%.0f s", seconds);
  else if (seconds < 5400)
    std::snprintf(buf, sizeof buf, "%.0f min", seconds / 60);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", seconds / 3600);
  return buf;
}

// Runs `todo` on `threads` workers; each row is appended to fd as it finishes.
long run_pool(const StudyRunner& runner, const std::vector<long>& todo, int fd, const fs::path& own,
              const SweepOptions& o) {
  const Study& s = runner.study();
  const fs::path series_dir = fs::path(o.out_dir) / "series";
  if (s.series_every) {
    std::error_code ec;
    if (fs::is_symlink(series_dir, ec))
      throw StudyError("sweep: '" + series_dir.string() + "' is a link; remove it");
    fs::create_directories(series_dir);
  }
  const long total = static_cast<long>(todo.size());
  std::atomic<long> next{0}, finished{0};
  std::atomic<bool> broken{false};
  std::mutex write_mutex;
  std::exception_ptr error;
  auto stopping = [&] { return broken.load() || (o.stop && o.stop->load()); };
  auto work = [&] {
    try {
      for (long k; !stopping() && (k = next++) < total;) {
        std::string series;
        const std::string row = runner.row(todo[k], s.series_every ? &series : nullptr);
        if (!series.empty()) {  // before the row: a recorded run has its series
          char name[40];
          std::snprintf(name, sizeof name, "run-%08ld.csv", todo[k]);
          write_whole(series_dir / name, series);
        }
        const std::lock_guard<std::mutex> lock(write_mutex);
        write_all(fd, row, own);
        ++finished;
      }
    } catch (...) {
      const std::lock_guard<std::mutex> lock(write_mutex);
      if (!error) error = std::current_exception();
      broken = true;
    }
  };
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> pool;
  try {
    for (int t = 0; t < std::max(1, o.threads); ++t) pool.emplace_back(work);
  } catch (const std::system_error& e) {  // no thread left on this machine
    broken = true;
    for (auto& t : pool) t.join();
    throw StudyError("sweep: cannot start thread " + std::to_string(pool.size() + 1) + " (" +
                     e.what() + "): give fewer --threads");
  }
  // Progress from this thread while the pool works: every 2 s, with the rate and the time left.
  double reported = 0;
  while (finished < total && !stopping()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const long f = finished;
    if (o.progress && elapsed - reported >= 2 && f > 0 && f < total) {
      reported = elapsed;
      const double rate = static_cast<double>(f) / elapsed;
      char line[160];
      std::snprintf(line, sizeof line,
                    "sweep: %ld of %ld runs (%.0f %%), %.3g runs/s, about %s left", f, total,
                    100.0 * static_cast<double>(f) / static_cast<double>(total), rate,
                    duration_text(static_cast<double>(total - f) / rate).c_str());
      o.progress(line);
    }
  }
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  return finished;
}

}  // namespace

std::string merge_rows(const StudyRunner& runner, const std::vector<std::string>& rows) {
  const long n = runner.study().num_runs();
  std::vector<const std::string*> by_run(n, nullptr);
  for (const auto& row : rows) {
    long run = -1;
    if (const std::string why = runner.row_problem(row, &run); !why.empty())
      throw StudyError("sweep: not a row of this study (" + why +
                       "): " + quoted_text(row.substr(0, 40)));
    if (by_run[run] && *by_run[run] != row)
      throw StudyError("sweep: run " + std::to_string(run) + " has two different rows");
    by_run[run] = &row;
  }
  std::string out = runner.header();
  for (long run = 0; run < n; ++run) {
    if (!by_run[run]) throw StudyError("sweep: run " + std::to_string(run) + " has no row");
    out += *by_run[run];
  }
  return out;
}

SweepSummary run_sweep(const StudyRunner& runner, const SweepOptions& o) {
  const long n = runner.study().num_runs();
  const fs::path dir(o.out_dir);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw StudyError("sweep: -o '" + dir.string() + "': not a folder that can be created or used" +
                     (ec ? " (" + ec.message() + ")" : ""));
  claim_folder(dir, runner);
  const fs::path own = dir / ("runs-" + std::to_string(o.shard.index) + "of" +
                              std::to_string(o.shard.count) + ".csv");
  // What the folder holds already, from every shard's file; the shard's own file is cut after
  // its last whole row (a killed sweep may have left half of one).
  std::map<long, std::string> rows;
  size_t own_complete = 0;
  for (const auto& f : row_files(dir)) {
    long first = -1;
    const size_t complete = read_rows(f, runner, rows, &first);
    if (f == own) own_complete = complete;
    // Rows of another spacearm, another CPU's libm or an edit would mix silently: each file's
    // first row must be what this sweep computes for its run.
    if (first >= 0 && runner.row(first) != rows.at(first))
      throw StudyError("sweep: '" + f.string() + "': run " + std::to_string(first) +
                       " differs from what this sweep computes (rows of another spacearm "
                       "version or machine, or edited); remove the file to run its rows again");
  }
  const int fd = open_shard_file(own, own_complete);
  struct Close {
    int fd;
    ~Close() { ::close(fd); }
  } close_at_end{fd};
  if (own_complete == 0) write_all(fd, runner.header(), own);

  SweepSummary sum;
  std::vector<long> todo;
  for (long run = o.shard.index - 1; run < n; run += o.shard.count, ++sum.shard_runs)
    if (rows.count(run))
      ++sum.already_done;
    else
      todo.push_back(run);
  rows.clear();
  sum.ran = run_pool(runner, todo, fd, own, o);
  sum.interrupted = sum.ran < static_cast<long>(todo.size());

  // results.csv once every run of the study is in the folder.
  rows = folder_rows(dir, runner);
  sum.study_done = static_cast<long>(rows.size());
  for (const auto& [run, row] : rows)
    if (run % o.shard.count == o.shard.index - 1 && failed_row(row)) ++sum.failed;
  if (sum.study_done == n) {
    std::vector<std::string> list;
    list.reserve(rows.size());
    for (auto& [run, row] : rows) list.push_back(std::move(row));
    sum.results = (dir / "results.csv").string();
    write_whole(sum.results, merge_rows(runner, list));
  }
  return sum;
}

}  // namespace spacearm
