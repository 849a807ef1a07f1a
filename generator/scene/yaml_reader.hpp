// Reading untrusted YAML files (scenes, studies): one document, bounded scalars, known keys
// only, numbers spelled strictly; every error names the file, the line and the field.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "planar_scene.hpp"

namespace spacearm {

// A C-like identifier: [A-Za-z][A-Za-z0-9_]*.
bool is_identifier(const std::string& s);
// A decimal number as YAML and strtod both read it: digits, a point, an exponent.
bool is_decimal(const std::string& s);
// Counts the YAML documents in `text`, stopping at `limit`.
int count_documents(const std::string& text, int limit);

// Reads one untrusted YAML file of some kind ("scene", "study"), collecting the context (file,
// line, field path) for error messages, which `raise` throws (as the kind's error type).
class YamlReader {
 public:
  using Raise = void (*)(const std::string& message);
  YamlReader(std::string kind, std::string source, Raise raise)
      : kind_(std::move(kind)), source_(std::move(source)), raise_(raise) {}

  // The one document of `text`; more than one, or text that is not YAML, fails.
  YAML::Node load(const std::string& text) const;

  [[noreturn]] void fail(const std::string& field, const std::string& what,
                         const YAML::Node& node = YAML::Node()) const {
    std::ostringstream msg;
    msg << kind_ << " '" << source_ << "'";
    if (node.IsDefined() && node.Mark().line >= 0) msg << " line " << node.Mark().line + 1;
    if (!field.empty()) msg << ", field '" << field << "'";
    msg << ": " << what;
    raise_(msg.str());
    throw std::logic_error("YamlReader: raise returned");  // raise must throw
  }

  // A mapping key as text; YAML also allows lists, mappings and nulls as keys.
  std::string key_text(const YAML::Node& key, const std::string& field) const {
    if (!key.IsScalar()) fail(field, std::string("expected a field name, got ") + kind(key), key);
    return bounded(key, field).Scalar();
  }

  // A scalar of at most kMaxScalarLength characters: every real scene value is short, and
  // the checks below (std::regex) should not see megabyte-long tokens.
  const YAML::Node& bounded(const YAML::Node& n, const std::string& field) const {
    static constexpr size_t kMaxScalarLength = 200;
    if (n.IsScalar() && n.Scalar().size() > kMaxScalarLength)
      fail(field,
           "value is too long (" + std::to_string(n.Scalar().size()) + " characters, at most " +
               std::to_string(kMaxScalarLength) + ")",
           n);
    return n;
  }

  static const char* kind(const YAML::Node& n) {
    if (n.IsMap()) return "a mapping";
    if (n.IsSequence()) return "a list";
    if (n.IsNull()) return "nothing (null)";
    return "a scalar";
  }

  // Rejects keys that are not in `allowed` and keys given twice.
  void check_keys(const YAML::Node& map, const std::string& field,
                  const std::set<std::string>& allowed) const {
    if (!map.IsMap()) fail(field, "expected a mapping", map);
    std::set<std::string> seen;
    for (const auto& kv : map) {
      const std::string key = key_text(kv.first, field);
      // A key is shown only if it looks like a field name: any text of a file that is not a
      // scene (a study may name /etc/shadow) stays out of the message.
      const bool shown = (is_identifier(key) && key.size() <= 24) || is_decimal(key);
      const std::string path =
          (field.empty() ? "" : field + ".") + (shown ? key : "<not a field name>");
      if (!allowed.count(key)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        const bool number = is_decimal(key);
        fail(path,
             "unknown field (allowed here: " + list + ")" +
                 (number ? "; a decimal comma? write numbers with a point, e.g. 3.0 not 3,0" : ""),
             kv.first);
      }
      if (!seen.insert(key).second) fail(path, "given more than once", kv.first);
    }
  }

  YAML::Node require(const YAML::Node& map, const std::string& key,
                     const std::string& field) const {
    YAML::Node n = map[key];
    if (!n.IsDefined() || n.IsNull())
      fail(field.empty() ? key : field + "." + key, "missing required field", map);
    return n;
  }

  Quantity quantity(const YAML::Node& n, const std::string& field) const {
    if (!n.IsScalar()) fail(field, "expected a number or a parameter name", n);
    const std::string text = bounded(n, field).Scalar();
    Quantity q;
    // YAML's spellings of infinity and NaN (.inf, -.Inf, .NaN, ...) are numbers, just not finite.
    static const std::set<std::string> yaml_special = {".inf",  ".Inf",  ".INF",  "+.inf",
                                                       "+.Inf", "+.INF", "-.inf", "-.Inf",
                                                       "-.INF", ".nan",  ".NaN",  ".NAN"};
    if (yaml_special.count(text)) fail(field, "value '" + text + "' is not finite", n);
    if (is_decimal(text)) {
      q.literal = text;
      q.value = std::strtod(text.c_str(), nullptr);
      if (!std::isfinite(q.value)) fail(field, "value '" + text + "' is not finite", n);
      // Physical values in SI units: magnitudes beyond 1e30 (or non-zero below 1e-30) are
      // mistakes, and products of them would overflow double in the generated code.
      const size_t e = text.find_first_of("eE");
      if (e != std::string::npos && text.size() - e > 5)
        fail(field,
             "value '" + text + "' has an exponent beyond the supported range (1e-30 .. 1e30)", n);
      if (std::abs(q.value) > 1e30 || (q.value != 0 && std::abs(q.value) < 1e-30))
        fail(field,
             "value '" + text + "' is outside the supported magnitude range 1e-30 .. 1e30 (or 0)",
             n);
      // A literal that is not zero but reads as 0 or a subnormal double has lost its digits.
      const bool nonzero_digits =
          text.substr(0, text.find_first_of("eE")).find_first_of("123456789") != std::string::npos;
      if (nonzero_digits && !(std::abs(q.value) >= DBL_MIN))
        fail(field,
             "value '" + text +
                 "' is too small for double precision (below 2.2e-308); write 0 for zero",
             n);
    } else if (is_identifier(text)) {
      if (text == "nan" || text == "NaN" || text == "inf" || text == "Inf")
        fail(field, "value '" + text + "' is not finite", n);
      q.parameter = text;
    } else {
      fail(field, "value '" + text + "' is neither a decimal number nor a parameter name", n);
    }
    return q;
  }

  const std::string& source() const { return source_; }

 private:
  std::string kind_, source_;
  Raise raise_;
};
// A scene's `parameters:` mapping (absent or null: none), each name an identifier that the
// generated code does not use itself, its nominal value a number.
std::vector<Parameter> read_scene_parameters(const YamlReader& r, const YAML::Node& node);

// A scene's declared parameters as its fields use them, for both kinds of scene: a quantity that
// names one is resolved to its nominal value and its index in params; one no field names is an
// error. Keeps a reference to `parameters` (the scene's own, alive while it is read).
class DeclaredParameters {
 public:
  DeclaredParameters(const YamlReader& r, const std::vector<Parameter>& parameters)
      : r_(r), parameters_(parameters) {}
  bool declared(const std::string& name) const;
  // q, resolved where it names a parameter (marked used); fails naming `field` where it names
  // none that is declared.
  Quantity resolved(Quantity q, const std::string& field, const YAML::Node& node);
  // Fails naming the first declared parameter that no field used (`node`: the mapping).
  void refuse_unused(const YAML::Node& node) const;

 private:
  const YamlReader& r_;
  const std::vector<Parameter>& parameters_;
  std::set<std::string> used_;
};

}  // namespace spacearm
