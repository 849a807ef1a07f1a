// The results folder of a sweep (sweep.hpp): study.id, study.key, one runs-IofN.csv per shard,
// series/, results.csv; and the thread pool that fills it. The folder is opened once through
// checked components (private_folder.hpp) and every file is reached relative to it, created
// with O_EXCL | O_NOFOLLOW or renamed into place: nothing planted there is written through.
// Each row of a shard file carries an HMAC-SHA-256 of the study's identity and the row, keyed
// by the folder's study.key (0600): an edited, forged or stale row is refused, never merged.
#include <fcntl.h>
#include <openssl/hmac.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <thread>

#include "private_folder.hpp"
#include "sweep.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace {

constexpr size_t kDigestChars = 64;  // HMAC-SHA-256 in hex

// The folder's own checks as the sweep's errors.
template <class F>
auto as_study_error(F&& f) -> decltype(f()) {
  return folder_errors_as<StudyError>("sweep: ", std::forward<F>(f));
}

// The results folder, open, with its path for messages.
struct Folder {
  Fd fd;
  std::string path;
  std::string shown(const std::string& name) const { return path + "/" + name; }
};

// create: a missing folder is made (-o); a folder to read (--merge) must exist.
Folder open_folder(const std::string& path, bool create = true) {
  return as_study_error([&] {
    return Folder{
        open_private_folder(path, create ? "sweep folder -o" : "sweep folder --merge", create,
                            create ? "remove it or give another folder (-o)"
                                   : "give the folder a shard's sweep wrote"),
        path};
  });
}

// The content of one of the folder's files; empty if absent. Refuses a link, a pipe or a file
// of someone else's.
std::string read_file_in(const Folder& dir, const std::string& name, bool* exists = nullptr) {
  return as_study_error([&] {
    const Fd fd = open_private_at(dir.fd.get(), name, false, dir.shown(name), "sweep file");
    if (exists) *exists = fd.valid();
    return fd.valid() ? read_all(fd.get(), dir.shown(name), size_t(1) << 40) : std::string();
  });
}

// Creates `name` with `text` whole or not at all, unless it exists: shards started together on
// a new folder each write a temporary and link it into place; all but one find it there.
// Returns the content the file has.
std::string create_once(const Folder& dir, const std::string& name, const std::string& text,
                        mode_t mode) {
  return as_study_error([&] {
    const std::string tmp = unique_name(name + ".tmp-");
    write_new_file_at(dir.fd.get(), tmp, text, dir.shown(tmp), mode);
    const bool created = ::linkat(dir.fd.get(), tmp.c_str(), dir.fd.get(), name.c_str(), 0) == 0;
    const int error = errno;
    ::unlinkat(dir.fd.get(), tmp.c_str(), 0);
    if (!created && error != EEXIST)
      throw StudyError("sweep: cannot create '" + dir.shown(name) + "': " + std::strerror(error));
    return created ? text : read_file_in(dir, name);
  });
}

// The names of the shard files (runs-*.csv), sorted.
std::vector<std::string> row_files(const Folder& dir) {
  std::vector<std::string> files;
  for (const auto& name : list_folder(dir.fd.get()))
    if (name.rfind("runs-", 0) == 0 && name.size() > 9 && name.substr(name.size() - 4) == ".csv")
      files.push_back(name);
  return files;
}

// The folder belongs to one study: study.id names it, and a different study is refused. A
// folder with rows but no study.id (deleted, or rows copied in) is refused too.
void claim_folder(const Folder& dir, const StudyRunner& runner) {
  const Study& s = runner.study();
  const std::string id = "spacearm sweep\nstudy " + s.identity + "\nruns " +
                         std::to_string(s.num_runs()) + "\n" + runner.header();
  bool exists = false;
  std::string found = read_file_in(dir, "study.id", &exists);
  if (!exists) {
    if (!row_files(dir).empty())
      throw StudyError("sweep: -o '" + dir.path +
                       "' holds rows (runs-*.csv) but no study.id, so nothing says which study "
                       "they belong to: give another folder, or remove them to start over");
    found = create_once(dir, "study.id", id, 0644);
  }
  if (found != id)
    throw StudyError("sweep: -o '" + dir.path +
                     "' holds the results of another study (or of this one before an edit; "
                     "see its study.id): give another folder, or remove it to start over");
}

// The folder's key for the rows' digests (32 random bytes in hex, readable by you alone).
std::string folder_key(const Folder& dir) {
  bool exists = false;
  std::string key = read_file_in(dir, "study.key", &exists);
  if (!exists) {
    if (!row_files(dir).empty())
      throw StudyError("sweep: -o '" + dir.path +
                       "' holds rows but no study.key to check them with: remove the "
                       "runs-*.csv files to run them again");
    const std::string fresh = as_study_error([] { return random_hex(32, "study.key"); });
    key = create_once(dir, "study.key", fresh + "\n", 0600);
  }
  if (key.size() != 65 || key.find_first_not_of("0123456789abcdef") != 64 || key[64] != '\n')
    throw StudyError("sweep: '" + dir.shown("study.key") +
                     "' is not a key spacearm wrote: remove the folder to start over");
  return key.substr(0, 64);
}

// HMAC-SHA-256 of the study's identity and a row, under the folder's key, in hex.
std::string row_digest(const std::string& key, const StudyRunner& runner, const std::string& row) {
  const std::string data = runner.study().identity + '\n' + row;
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
            reinterpret_cast<const unsigned char*>(data.data()), data.size(), md, &length))
    throw StudyError("sweep: HMAC-SHA-256 failed (libcrypto)");
  return hex_text(md, length);
}

std::string signed_row(const std::string& key, const StudyRunner& runner, const std::string& row) {
  return row.substr(0, row.size() - 1) + "," + row_digest(key, runner, row) + "\n";
}

bool failed_row(const std::string& row) {
  return row.compare(row.find(',') + 1, 7, "failed,") == 0;
}

// Adds the rows of one runs-*.csv file by run, each checked against its digest; a line cut by a
// kill (no newline) is left out. Returns the file's length up to its last complete line.
// first: receives the file's first run (-1 if none).
size_t read_rows(const Folder& dir, const std::string& name, const std::string& key,
                 const StudyRunner& runner, std::map<long, std::string>& rows,
                 long* first = nullptr) {
  if (first) *first = -1;
  const std::string all = read_file_in(dir, name), header = shard_header(runner);
  auto fail = [&](long line, const std::string& why) {
    throw StudyError("sweep: '" + dir.shown(name) + "' line " + std::to_string(line) + ": " + why +
                     "; remove the file to run its rows again");
  };
  if (all.size() < header.size()) return 0;  // cut while its header was written
  if (all.compare(0, header.size(), header) != 0) fail(1, "not the study's header");
  size_t at = header.size();
  for (long line = 2;; ++line) {
    const size_t nl = all.find('\n', at);
    if (nl == std::string::npos) break;
    if (nl - at < kDigestChars + 2 || all[nl - kDigestChars - 1] != ',')
      fail(line, "no digest at the end of the line");
    const std::string row = all.substr(at, nl - kDigestChars - 1 - at) + "\n";
    long run = -1;
    if (const std::string why = runner.row_problem(row, &run); !why.empty())
      fail(line, "not a row of this study: " + why);
    if (all.compare(nl - kDigestChars, kDigestChars, row_digest(key, runner, row)) != 0)
      fail(line,
           "its digest does not match: the row was edited, or written for another study "
           "or folder");
    if (first && *first < 0) *first = run;
    const auto [it, added] = rows.emplace(run, row);
    if (!added && it->second != row)
      fail(line, "run " + std::to_string(run) +
                     " has another row already (here or in another runs-*.csv file)");
    at = nl + 1;
  }
  return at;
}

// The shard's own row file: locked against a second sweep, cut after its last whole row.
Fd open_shard_file(const Folder& dir, const std::string& name, size_t complete) {
  const std::string shown = dir.shown(name);
  Fd fd(::openat(dir.fd.get(), name.c_str(),
                 O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK | O_NOCTTY, 0644));
  if (!fd.valid())
    throw StudyError("sweep: cannot open '" + shown + "': " + std::strerror(errno) +
                     (errno == ELOOP ? " (a link: remove it)" : ""));
  struct stat st;
  if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode))
    throw StudyError("sweep: '" + shown + "' is not a plain file (a pipe or a device); remove it");
  as_study_error([&] { check_private(st, shown, "sweep file", "remove it"); });
  if (::flock(fd.get(), LOCK_EX | LOCK_NB) != 0)
    throw StudyError("sweep: another sweep is writing '" + shown +
                     "' (the same shard twice at once?)");
  if (::ftruncate(fd.get(), static_cast<off_t>(complete)) != 0 ||
      ::lseek(fd.get(), 0, SEEK_END) < 0)
    throw StudyError("sweep: cannot prepare '" + shown + "': " + std::strerror(errno));
  return fd;
}

// Whole rows with one write each (no stdio buffer): a kill loses at most the row being written.
void write_all(int fd, const std::string& text, const std::string& shown) {
  for (size_t at = 0; at < text.size();) {
    const ssize_t n = ::write(fd, text.data() + at, text.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw StudyError("sweep: cannot write '" + shown + "': " + std::strerror(errno));
    at += static_cast<size_t>(n);
  }
}

// The series folder, created private if missing.
Folder open_series(const Folder& dir) {
  return as_study_error([&] {
    if (::mkdirat(dir.fd.get(), "series", 0755) != 0 && errno != EEXIST)
      throw StudyError("sweep: cannot create '" + dir.shown("series") +
                       "': " + std::strerror(errno));
    Fd fd = open_private_at(dir.fd.get(), "series", true, dir.shown("series"), "sweep folder");
    if (!fd.valid()) throw StudyError("sweep: '" + dir.shown("series") + "' vanished");
    return Folder{std::move(fd), dir.shown("series")};
  });
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
long run_pool(const StudyRunner& runner, const std::vector<long>& todo, const Folder& dir, int fd,
              const std::string& own, const std::string& key, const SweepOptions& o) {
  const Study& s = runner.study();
  const Folder series_dir = s.series_every ? open_series(dir) : Folder{Fd(), ""};
  const long total = static_cast<long>(todo.size());
  std::atomic<long> next{0}, finished{0};
  std::atomic<bool> broken{false};
  std::mutex write_mutex;
  std::exception_ptr error;
  auto stopping = [&] { return broken.load() || (o.stop && o.stop->load()); };
  auto work = [&] {
    try {
      // The next group of runs the runner integrates at once (StudyRunner::lanes()).
      const long group = std::max(1, runner.lanes());
      for (long k; !stopping() && (k = next.fetch_add(group)) < total;) {
        const std::vector<long> runs(todo.begin() + k, todo.begin() + std::min(total, k + group));
        std::vector<std::string> series;
        const std::vector<std::string> rows = runner.rows(runs, s.series_every ? &series : nullptr);
        for (size_t i = 0; i < runs.size(); ++i) {
          if (s.series_every &&
              !series[i].empty()) {  // before the row: a recorded run has its series
            char name[40];
            std::snprintf(name, sizeof name, "run-%08ld.csv", runs[i]);
            as_study_error([&] {
              replace_file_at(series_dir.fd.get(), name, series[i], series_dir.shown(name));
            });
          }
          const std::string line = signed_row(key, runner, rows[i]);
          const std::lock_guard<std::mutex> lock(write_mutex);
          write_all(fd, line, own);
          ++finished;
        }
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

std::string shard_header(const StudyRunner& runner) {
  const std::string& h = runner.header();
  return h.substr(0, h.size() - 1) + ",digest\n";
}

SweepSummary run_sweep(const StudyRunner& runner, const SweepOptions& o) {
  const long n = runner.study().num_runs();
  const Folder dir = open_folder(o.out_dir);
  claim_folder(dir, runner);
  const std::string key = folder_key(dir);
  const std::string own =
      "runs-" + std::to_string(o.shard.index) + "of" + std::to_string(o.shard.count) + ".csv";
  // What the folder holds already, from every shard's file; the shard's own file is cut after
  // its last whole row (a killed sweep may have left half of one).
  std::map<long, std::string> rows;
  size_t own_complete = 0;
  for (const auto& f : row_files(dir)) {
    long first = -1;
    const size_t complete = read_rows(dir, f, key, runner, rows, &first);
    if (f == own) own_complete = complete;
    // Rows of another spacearm, another CPU's libm would mix silently: each file's first row
    // must be what this sweep computes for its run.
    if (first >= 0 && runner.row(first) != rows.at(first))
      throw StudyError("sweep: '" + dir.shown(f) + "': run " + std::to_string(first) +
                       " differs from what this sweep computes (rows of another spacearm "
                       "version or machine, or edited); remove the file to run its rows again");
  }
  const Fd fd = open_shard_file(dir, own, own_complete);
  if (own_complete == 0) write_all(fd.get(), shard_header(runner), dir.shown(own));

  SweepSummary sum;
  std::vector<long> todo;
  for (long run = o.shard.index - 1; run < n; run += o.shard.count, ++sum.shard_runs)
    if (rows.count(run))
      ++sum.already_done;
    else
      todo.push_back(run);
  rows.clear();
  sum.ran = run_pool(runner, todo, dir, fd.get(), dir.shown(own), key, o);
  sum.interrupted = sum.ran < static_cast<long>(todo.size());

  // results.csv once every run of the study is in the folder.
  for (const auto& f : row_files(dir)) read_rows(dir, f, key, runner, rows);
  sum.study_done = static_cast<long>(rows.size());
  for (const auto& [run, row] : rows)
    if (run % o.shard.count == o.shard.index - 1 && failed_row(row)) ++sum.failed;
  if (sum.study_done == n) {
    std::vector<std::string> list;
    list.reserve(rows.size());
    for (auto& [run, row] : rows) list.push_back(std::move(row));
    sum.results = dir.shown("results.csv");
    as_study_error([&] {
      replace_file_at(dir.fd.get(), "results.csv", merge_rows(runner, list), sum.results);
    });
  }
  return sum;
}

std::string merge_sweeps(const StudyRunner& runner, const std::vector<std::string>& dirs,
                         const std::string& out_dir) {
  const long n = runner.study().num_runs();
  if (dirs.empty()) throw StudyError("sweep: --merge needs at least one folder");
  // Each folder's rows under that folder's own key and study identity: a row another folder
  // signed, an edited one or one of another study is refused, never merged.
  std::map<long, std::string> rows;
  for (const std::string& path : dirs) {
    const Folder dir = open_folder(path, false);
    bool has_id = false, has_key = false;
    read_file_in(dir, "study.id", &has_id);
    read_file_in(dir, "study.key", &has_key);
    if (!has_id || !has_key)
      throw StudyError("sweep: --merge '" + path + "' has no " +
                       (has_id ? "study.key" : "study.id") +
                       ": not a sweep's folder (copy the whole folder of each shard, study.id and "
                       "study.key with its runs-*.csv)");
    claim_folder(dir, runner);
    const std::string key = folder_key(dir);
    const std::vector<std::string> files = row_files(dir);
    if (files.empty()) throw StudyError("sweep: --merge '" + path + "' holds no runs-*.csv");
    for (const auto& f : files) {
      long first = -1;
      read_rows(dir, f, key, runner, rows, &first);
      // As run_sweep: rows of another spacearm or machine would mix silently.
      if (first >= 0 && runner.row(first) != rows.at(first))
        throw StudyError("sweep: '" + dir.shown(f) + "': run " + std::to_string(first) +
                         " differs from what this spacearm computes (rows of another version "
                         "or machine, or edited)");
    }
  }
  if (static_cast<long>(rows.size()) != n) {
    std::string missing;
    int shown = 0;
    for (long run = 0; run < n && shown < 10; ++run)
      if (!rows.count(run)) missing += (shown++ ? ", " : "") + std::to_string(run);
    throw StudyError("sweep: --merge: the folders hold " + std::to_string(rows.size()) +
                     " of the " + std::to_string(n) + " runs; missing runs " + missing +
                     (static_cast<long>(rows.size()) + shown < n ? ", ..." : "") +
                     " (run their shards, then merge again)");
  }
  std::vector<std::string> list;
  for (auto& [run, row] : rows) list.push_back(std::move(row));
  return write_results(runner, out_dir, list);
}

void claim_results_folder(const StudyRunner& runner, const std::string& out_dir) {
  claim_folder(open_folder(out_dir), runner);
}

std::string write_results(const StudyRunner& runner, const std::string& out_dir,
                          const std::vector<std::string>& rows) {
  const std::string text = merge_rows(runner, rows);  // checks every row before any write
  const Folder dir = open_folder(out_dir);
  claim_folder(dir, runner);
  as_study_error(
      [&] { replace_file_at(dir.fd.get(), "results.csv", text, dir.shown("results.csv")); });
  return dir.shown("results.csv");
}

}  // namespace spacearm
