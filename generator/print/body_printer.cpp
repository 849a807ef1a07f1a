#include "body_printer.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "emitted_text.hpp"

namespace spacearm {

// The printer itself (BodyPrinter forwards to it).
class BodyPrinterImpl {
 public:
  BodyPrinterImpl(const Program& p, const std::vector<Assignment>& assignments, bool plain,
                  Spelling spelling = Spelling::eigen, int per_part = 0)
      : p_(p), plain_(plain), spelling_(spelling) {
    std::vector<SRef> roots;  // each once, as FunctionSpec::roots()
    std::set<SRef> seen;
    for (const Assignment& a : assignments)
      if (a.source.empty() && seen.insert(a.root).second) roots.push_back(a.root);
    order_ = p_.schedule(roots);
    if (!plain_) batch_trig();
    for (int id : order_)
      for (const SRef& a : p_.node(id).args)
        if (a.id >= 0) ++uses_[a.id];
    for (const SRef& r : roots)
      if (r.id >= 0) ++uses_[r.id];
    name_temporaries(assignments, per_part);
  }

  int num_parts() const { return static_cast<int>(parts_.size()); }
  int work_size() const { return work_size_; }
  bool has_trig_batches() const { return !batches_.empty(); }
  // The statements of part k ("  const T t3 = ...;", "  w[2] = ...;", "  M[0] = ...;").
  const std::string& part(int k) const { return parts_[k]; }

  std::string value(const SRef& root) const {
    return root.id < 0 ? "T(0)" : (root.neg ? "-" + wrap(root.id, 1) : ref(root.id));
  }

 private:
  const Program& p_;
  bool plain_;
  Spelling spelling_;
  std::vector<int> order_;
  std::map<int, int> uses_;
  std::map<int, std::string> names_;
  std::vector<std::string> parts_;
  int work_size_ = 0;
  // sin/cos nodes printed from one sincos_batch call: node -> (batch, angle), and each batch's
  // angles.
  std::map<int, std::pair<int, int>> batch_of_;
  std::vector<std::vector<int>> batches_;

  bool is_trig(int id) const {
    const auto k = p_.node(id).kind;
    return k == Program::Kind::sin || k == Program::Kind::cos;
  }

  // The sin/cos nodes whose angles depend on L other sin/cos calls form level L, computed by one
  // sincos_batch call (vectorized where the build allows: kTrigBatchHelper), so that every sine
  // of a model comes from the same implementation. The schedule is reordered by level, each
  // level's call as early as it can be: first the statements it needs, then the call, then the
  // rest.
  void batch_trig() {
    std::map<int, int> level;
    std::map<int, std::vector<int>> angles;  // per level, in schedule order, each once
    for (int id : order_) {
      int l = 0;
      for (const SRef& a : p_.node(id).args)
        if (a.id >= 0) l = std::max(l, level[a.id] + (is_trig(a.id) ? 1 : 0));
      level[id] = l;
      if (!is_trig(id)) continue;
      std::vector<int>& v = angles[l];
      if (std::find(v.begin(), v.end(), p_.node(id).args[0].id) == v.end())
        v.push_back(p_.node(id).args[0].id);
    }
    std::map<int, int> batch_at_level;
    for (const auto& [l, v] : angles) {
      batch_at_level[l] = static_cast<int>(batches_.size());
      batches_.push_back(v);
    }
    if (batches_.empty()) return;
    // The statements of each level that the calls of that level read.
    std::set<int> needed;
    for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
      if (!is_trig(*it) && !needed.count(*it)) continue;
      for (const SRef& a : p_.node(*it).args)
        if (a.id >= 0 && !is_trig(a.id) && level[a.id] == level[*it]) needed.insert(a.id);
    }
    std::map<int, int> key;
    for (int id : order_) key[id] = 2 * level[id] + (is_trig(id) ? 1 : needed.count(id) ? 0 : 2);
    std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) { return key[a] < key[b]; });
    for (int id : order_) {
      if (!is_trig(id)) continue;
      const int b = batch_at_level[level[id]];
      const auto& v = batches_[b];
      const auto j = std::find(v.begin(), v.end(), p_.node(id).args[0].id) - v.begin();
      batch_of_[id] = {b, static_cast<int>(j)};
    }
  }

  // The statements of batch b's call, before its first sin/cos is read.
  std::string batch_call(int b) const {
    const std::string n = std::to_string(b), k = std::to_string(batches_[b].size());
    std::string list;
    for (int a : batches_[b]) list += (list.empty() ? "" : ", ") + ref(a);
    return "  const T angles" + n + "[" + k + "] = {" + list + "};\n  T sines" + n + "[" + k +
           "], cosines" + n + "[" + k + "];\n  sincos_batch(angles" + n + ", sines" + n +
           ", cosines" + n + ");\n";
  }

  bool named(int id) const {
    const auto k = p_.node(id).kind;
    const bool is_op = k != Program::Kind::input && k != Program::Kind::constant;
    const bool trig = k == Program::Kind::sin || k == Program::Kind::cos ||
                      k == Program::Kind::tanh || k == Program::Kind::exp;
    return !plain_ && is_op && (trig || uses_.at(id) >= 2);
  }
  // The named nodes that printing node id's operands refers to (unnamed ones print inline).
  void operands(int id, std::vector<int>& out) const {
    for (const SRef& a : p_.node(id).args) {
      if (a.id < 0) continue;
      if (named(a.id))
        out.push_back(a.id);
      else
        operands(a.id, out);
    }
  }
  std::vector<int> references(const SRef& r) const {
    std::vector<int> out;
    if (r.id >= 0) (named(r.id) ? out.push_back(r.id) : operands(r.id, out));
    return out;
  }

  // Parts, names (t<k> within a part, w[slot] across parts) and the statements of each part.
  void name_temporaries(const std::vector<Assignment>& assignments, int max_per_part) {
    std::vector<int> temps;
    for (int id : order_)
      if (named(id)) temps.push_back(id);
    const int total = static_cast<int>(temps.size() + assignments.size());
    const int per_part = max_per_part > 0 && total > max_per_part ? max_per_part : total + 1;
    // The part of each temporary and of each assignment (that of its last operand), and the
    // last part that reads each temporary.
    std::map<int, int> part_of, last_read;
    for (size_t k = 0; k < temps.size(); ++k) part_of[temps[k]] = static_cast<int>(k) / per_part;
    std::map<int, int> batch_part;  // a batch's sin/cos stay in the part of its call
    for (int id : temps)
      if (batch_of_.count(id))
        part_of[id] = batch_part.emplace(batch_of_.at(id).first, part_of[id]).first->second;
    for (int id : temps) {
      std::vector<int> refs;
      operands(id, refs);
      for (int r : refs) last_read[r] = std::max(last_read[r], part_of[id]);
    }
    std::vector<int> assignment_part;
    for (const Assignment& a : assignments) {
      const std::vector<int> refs = references(a.root);
      int part = 0;
      for (int r : refs) part = std::max(part, part_of[r]);
      for (int r : refs) last_read[r] = std::max(last_read[r], part);
      assignment_part.push_back(part);
    }
    const int num_parts =
        std::max(temps.empty() ? 1 : part_of[temps.back()] + 1,
                 assignment_part.empty()
                     ? 1
                     : *std::max_element(assignment_part.begin(), assignment_part.end()) + 1);
    // A copy of another entry runs last, when every entry has been written.
    for (size_t k = 0; k < assignments.size(); ++k)
      if (!assignments[k].source.empty()) assignment_part[k] = num_parts - 1;
    assign_slots(temps, part_of, last_read);
    // The statements, part by part.
    parts_.assign(num_parts, "");
    std::set<int> called;
    for (int id : temps) {
      const std::string& name = names_[id];
      if (batch_of_.count(id) && called.insert(batch_of_.at(id).first).second)
        parts_[part_of[id]] += batch_call(batch_of_.at(id).first);
      parts_[part_of[id]] +=
          (name[0] == 'w' ? "  " : "  const T ") + name + " = " + print_node(id) + ";\n";
    }
    for (size_t k = 0; k < assignments.size(); ++k) {
      const Assignment& a = assignments[k];
      parts_[assignment_part[k]] +=
          a.target.empty()
              ? "  return " + value(a.root) + ";\n"
              : "  " + a.target + " = " + (a.source.empty() ? value(a.root) : a.source) + ";\n";
    }
  }

  // A temporary read only in its own part is a local t<k>; one read later takes a slot w[i],
  // free again after its last reader's part.
  void assign_slots(const std::vector<int>& temps, std::map<int, int>& part_of,
                    std::map<int, int>& last_read) {
    std::vector<int> free_after;  // per slot: the last part that reads its value
    int next_local = 0;
    for (int id : temps) {
      const int part = part_of[id], last = last_read.count(id) ? last_read[id] : part;
      if (last <= part) {
        names_[id] = "t" + std::to_string(next_local++);
        continue;
      }
      size_t slot = 0;
      while (slot < free_after.size() && free_after[slot] >= part) ++slot;
      if (slot == free_after.size()) free_after.push_back(0);
      free_after[slot] = last;
      names_[id] = "w[" + std::to_string(slot) + "]";
    }
    work_size_ = static_cast<int>(free_after.size());
  }

  std::string ref(int id) const {
    auto it = names_.find(id);
    return it != names_.end() ? it->second : print_node(id);
  }

  // precedence: 0 sum context, 1 product, 2 divisor/negation
  std::string wrap(int id, int context) const {
    const auto& n = p_.node(id);
    // A sum left with one operand by the CSE pass is that operand, possibly negated.
    if (!names_.count(id) && n.kind == Program::Kind::add && n.args.size() == 1) {
      const SRef a = n.args[0];
      if (!a.neg) return wrap(a.id, context);
      const std::string neg = "-" + wrap(a.id, 2);
      return context >= 1 ? "(" + neg + ")" : neg;
    }
    const std::string s = ref(id);
    if (names_.count(id)) return s;
    const auto k = n.kind;
    const bool needs = (k == Program::Kind::add && n.args.size() > 1 && context >= 1) ||
                       ((k == Program::Kind::mul || k == Program::Kind::div) && context >= 2) ||
                       (context >= 1 && !s.empty() && s[0] == '-');
    return needs ? "(" + s + ")" : s;
  }

  std::string print_node(int id) const {
    const auto& n = p_.node(id);
    switch (n.kind) {
      case Program::Kind::input:
        return spelling_ == Spelling::eigen ? n.text + "(" + std::to_string(n.index) + ")"
                                            : n.text + "[" + std::to_string(n.index) + "]";
      case Program::Kind::constant:
        return "T(" + n.text + ")";
      case Program::Kind::sin:
      case Program::Kind::cos: {
        const bool sin = n.kind == Program::Kind::sin;
        const auto batch = batch_of_.find(id);
        if (batch == batch_of_.end()) return (sin ? "sin(" : "cos(") + ref(n.args[0].id) + ")";
        return (sin ? "sines" : "cosines") + std::to_string(batch->second.first) + "[" +
               std::to_string(batch->second.second) + "]";
      }
      case Program::Kind::tanh:
        return "tanh(" + ref(n.args[0].id) + ")";
      case Program::Kind::exp:
        return "exp(" + value(n.args[0]) + ")";
      case Program::Kind::pow:
        return "pow(" + ref(n.args[0].id) + ", " + n.text + ")";
      case Program::Kind::div:
        return wrap(n.args[0].id, 1) + " / " + wrap(n.args[1].id, 2);
      case Program::Kind::mul: {
        std::string s;
        for (const SRef& a : n.args) s += (s.empty() ? "" : " * ") + wrap(a.id, 1);
        return s;
      }
      case Program::Kind::add: {
        std::vector<SRef> terms = n.args;
        std::stable_partition(terms.begin(), terms.end(), [](const SRef& a) { return !a.neg; });
        std::string s;
        for (const SRef& a : terms) {
          if (s.empty())
            s = (a.neg ? "-" + wrap(a.id, 2) : wrap(a.id, 0));
          else
            s += (a.neg ? " - " + wrap(a.id, 1) : " + " + wrap(a.id, 0));
        }
        return s;
      }
    }
    return "";
  }
};

BodyPrinter::BodyPrinter(const Program& p, const std::vector<Assignment>& assignments, bool plain,
                         Spelling spelling, int per_part)
    : impl_(std::make_unique<BodyPrinterImpl>(p, assignments, plain, spelling, per_part)) {}
BodyPrinter::~BodyPrinter() = default;
int BodyPrinter::num_parts() const { return impl_->num_parts(); }
int BodyPrinter::work_size() const { return impl_->work_size(); }
bool BodyPrinter::has_trig_batches() const { return impl_->has_trig_batches(); }
const std::string& BodyPrinter::part(int k) const { return impl_->part(k); }
std::string BodyPrinter::value(const SRef& root) const { return impl_->value(root); }

}  // namespace spacearm
