#include "yaml_reader.hpp"

#include <yaml-cpp/eventhandler.h>

#include <cfloat>
#include <cmath>
#include <regex>
#include <sstream>

namespace spacearm {

bool is_identifier(const std::string& s) {
  static const std::regex re("[A-Za-z][A-Za-z0-9_]*");
  return std::regex_match(s, re);
}

bool is_decimal(const std::string& s) {
  static const std::regex re(R"([+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?)");
  return std::regex_match(s, re);
}

// Counts the YAML documents in `text`, stopping at `limit`: YAML::LoadAll never returns on
// some malformed input (fuzz/regressions/loadall_endless_documents.yaml), so the documents
// are walked with a parser that builds nothing.
int count_documents(const std::string& text, int limit) {
  struct Ignore : YAML::EventHandler {
    void OnDocumentStart(const YAML::Mark&) override {}
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
    void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
    void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  const std::string&) override {}
    void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                         YAML::EmitterStyle::value) override {}
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                    YAML::EmitterStyle::value) override {}
    void OnMapEnd() override {}
  } ignore;
  std::istringstream in(text);
  YAML::Parser parser(in);
  int documents = 0;
  while (documents < limit && parser.HandleNextDocument(ignore)) ++documents;
  return documents;
}

YAML::Node YamlReader::load(const std::string& text) const {
  YAML::Node root;
  try {
    root = YAML::Load(text);
    // A second document after `---` would be ignored: refuse it instead.
    if (count_documents(text, 2) > 1)
      fail("", "holds more than one YAML document (separated by ---); give one " + kind_);
  } catch (const YAML::Exception& e) {
    fail("", std::string("not valid YAML: ") + e.what());
  }
  return root;
}

bool DeclaredParameters::declared(const std::string& name) const {
  for (const Parameter& p : parameters_)
    if (p.name == name) return true;
  return false;
}

Quantity DeclaredParameters::resolved(Quantity q, const std::string& field,
                                      const YAML::Node& node) {
  if (!q.is_parameter()) return q;
  for (size_t i = 0; i < parameters_.size(); ++i)
    if (parameters_[i].name == q.parameter) {
      used_.insert(q.parameter);
      q.index = static_cast<int>(i);
      q.value = parameters_[i].nominal.value;
      return q;
    }
  r_.fail(field,
          "refers to parameter '" + q.parameter + "', which is not declared under 'parameters'",
          node);
}

void DeclaredParameters::refuse_unused(const YAML::Node& node) const {
  for (const Parameter& p : parameters_)
    if (!used_.count(p.name))
      r_.fail("parameters." + p.name, "parameter '" + p.name + "' is declared but never used",
              node);
}

}  // namespace spacearm
