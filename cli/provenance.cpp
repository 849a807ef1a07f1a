#include "provenance.hpp"

#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "version.hpp"
#include "private_folder.hpp"

namespace spacearm::cli {

namespace {

// The file's size and modification time in ns; false if it is not a regular file.
bool stamp(const std::string& path, long long& size, long long& mtime_ns) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  size = static_cast<long long>(st.st_size);
  mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
  return true;
}

}  // namespace

std::string provenance_path(const std::string& csv) { return csv + ".provenance.json"; }

void write_provenance(const std::string& csv, Provenance p) {
  if (csv.empty() || csv == "-") return;  // standard output: no file to sit beside
  try {
    std::error_code ec;
    p.folder = std::filesystem::current_path(ec).string();
    p.scene = std::filesystem::absolute(p.scene, ec).string();
    p.version = kGeneratorVersion;
    if (!stamp(csv, p.csv_size, p.csv_mtime_ns)) return;  // not a file (a pipe's name is fine)
    nlohmann::json parameters = nlohmann::json::object();
    for (const auto& [name, value] : p.parameters) parameters[name] = value;
    const nlohmann::json j = {
        {"command", p.command},          {"folder", p.folder},    {"scene", p.scene},
        {"parameters", parameters},      {"spacearm", p.version}, {"csv_size", p.csv_size},
        {"csv_mtime_ns", p.csv_mtime_ns}};
    replace_file(provenance_path(csv),
                 j.dump(2, ' ', true, nlohmann::json::error_handler_t::replace) + "\n", 0644);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "spacearm: warning: the run's provenance was not written: %s\n", e.what());
  }
}

std::optional<Provenance> read_provenance(const std::string& csv, bool* stale) {
  if (stale) *stale = false;
  const std::string path = provenance_path(csv);
  struct stat st;
  if (::lstat(path.c_str(), &st) != 0) return std::nullopt;
  const std::string what = "the run's provenance '" + path + "'";
  // spacearm writes the record as a file; a link could point at any file (/etc/shadow), whose
  // text must not reach a message or the page.
  if (S_ISLNK(st.st_mode))
    throw std::invalid_argument(what +
                                " is a symbolic link, not the record spacearm wrote; "
                                "remove it");
  std::string text;
  try {
    text = read_regular_file(path, "view", size_t(1) << 20);
  } catch (const FolderError& e) {
    throw std::invalid_argument(e.what());
  }
  // Every rejection is one of spacearm's own sentences: nlohmann's messages may quote the text
  // (a number too large quotes its digits), and the record may be any file.
  const auto reject = [&what](const std::string& why) {
    return std::invalid_argument(what + ": not spacearm's provenance (" + why +
                                 "); remove it or fix it");
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw reject("not JSON at byte " + std::to_string(e.byte));
  } catch (const nlohmann::json::exception&) {  // a number too large for a double
    throw reject("a number out of range");
  }
  if (!j.is_object()) throw reject("not a JSON object");
  const auto field = [&](const char* name, bool (nlohmann::json::*is)() const noexcept,
                         const char* kind) -> const nlohmann::json& {
    const auto it = j.find(name);
    if (it == j.end()) throw reject(std::string("field '") + name + "' missing");
    if (!((*it).*is)()) throw reject(std::string("field '") + name + "' is not " + kind);
    return *it;
  };
  using json = nlohmann::json;
  Provenance p;
  p.command = field("command", &json::is_string, "a string").get<std::string>();
  p.folder = field("folder", &json::is_string, "a string").get<std::string>();
  p.scene = field("scene", &json::is_string, "a string").get<std::string>();
  p.version = field("spacearm", &json::is_string, "a string").get<std::string>();
  for (const auto& [name, value] : field("parameters", &json::is_object, "an object").items()) {
    if (!value.is_number()) throw reject("a parameter's value is not a number");
    p.parameters.push_back({name, value.get<double>()});
  }
  p.csv_size = field("csv_size", &json::is_number_integer, "an integer").get<long long>();
  p.csv_mtime_ns = field("csv_mtime_ns", &json::is_number_integer, "an integer").get<long long>();
  long long size = -2, mtime = -2;
  if (!stamp(csv, size, mtime) || size != p.csv_size || mtime != p.csv_mtime_ns) {
    if (stale) *stale = true;
    return std::nullopt;
  }
  return p;
}

}  // namespace spacearm::cli
