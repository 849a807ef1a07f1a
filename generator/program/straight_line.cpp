#include "straight_line.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace spacearm {

SRef Program::intern(Node node) {
  auto key = std::make_tuple(static_cast<int>(node.kind), node.args, node.text, node.index);
  if (share_) {
    auto it = index_.find(key);
    if (it != index_.end()) return {it->second, false};
  }
  nodes_.push_back(std::move(node));
  const int id = static_cast<int>(nodes_.size()) - 1;
  if (share_) index_[key] = id;
  return {id, false};
}

SRef Program::input(const std::string& array, int index) {
  return intern({Kind::input, {}, array, 0, index});
}

SRef Program::constant(double value) {
  if (value == 0 || !std::isfinite(value))
    throw std::logic_error("constant must be finite and non-zero");
  char buf[64];
  // Shortest text that reads back as the same double.
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, std::fabs(value));
    if (std::strtod(buf, nullptr) == std::fabs(value)) break;
  }
  SRef r = intern({Kind::constant, {}, buf, std::fabs(value)});
  r.neg = value < 0;
  return r;
}

SRef Program::add(std::vector<SRef> terms) {
  terms.erase(std::remove_if(terms.begin(), terms.end(), [](const SRef& t) { return t.id < 0; }),
              terms.end());
  if (terms.empty()) return zero();
  if (terms.size() == 1) return terms[0];
  std::sort(terms.begin(), terms.end());
  // Keep a positive term available to lead the sum; pull the sign out if none is.
  const bool all_negative =
      std::all_of(terms.begin(), terms.end(), [](const SRef& t) { return t.neg; });
  if (all_negative)
    for (auto& t : terms) t.neg = false;
  SRef r = intern({Kind::add, terms, "", 0});
  r.neg = all_negative;
  return r;
}

SRef Program::mul(std::vector<SRef> factors) {
  bool neg = false;
  std::vector<SRef> f;
  for (SRef x : factors) {
    if (x.id < 0) return zero();
    neg ^= x.neg;
    x.neg = false;
    // Multiplying by the constant 1 is no operation.
    if (nodes_[x.id].kind == Kind::constant && nodes_[x.id].value == 1.0) continue;
    f.push_back(x);
  }
  SRef r;
  if (f.empty()) {
    r = constant(1.0);
  } else if (f.size() == 1) {
    r = f[0];
  } else {
    std::sort(f.begin(), f.end());
    r = intern({Kind::mul, f, "", 0});
  }
  r.neg ^= neg;
  return r;
}

SRef Program::div(SRef numerator, SRef denominator) {
  if (denominator.id < 0) throw std::logic_error("division by zero in generated code");
  if (numerator.id < 0) return zero();
  const bool neg = numerator.neg != denominator.neg;
  numerator.neg = denominator.neg = false;
  SRef r = intern({Kind::div, {numerator, denominator}, "", 0});
  r.neg = neg;
  return r;
}

SRef Program::sin(SRef angle) {
  if (angle.id < 0) return zero();
  SRef r = intern({Kind::sin, {{angle.id, false}}, "", 0});
  r.neg = angle.neg;  // sin(-x) = -sin(x)
  return r;
}

SRef Program::cos(SRef angle) {
  if (angle.id < 0) return constant(1.0);
  return intern({Kind::cos, {{angle.id, false}}, "", 0});
}

SRef Program::tanh(SRef x) {
  if (x.id < 0) return zero();
  SRef r = intern({Kind::tanh, {{x.id, false}}, "", 0});
  r.neg = x.neg;  // tanh(-x) = -tanh(x)
  return r;
}

SRef Program::exp(SRef x) {
  if (x.id < 0) return constant(1.0);
  return intern({Kind::exp, {x}, "", 0});
}

SRef Program::pow(SRef base, int exponent) {
  if (share_) throw std::logic_error("pow is only for unshared (baseline) programs");
  if (base.id < 0) return zero();
  SRef r = intern(
      {Kind::pow, {{base.id, false}}, std::to_string(exponent), static_cast<double>(exponent)});
  r.neg = base.neg && exponent % 2 != 0;
  return r;
}

namespace {

using Pair = std::pair<SRef, SRef>;

// The pair (a, b) in a canonical form: ordered, first operand not negated. flipped: the pair
// was negated to get there (a sum's (b - a) is -(a - b)).
Pair canonical(SRef a, SRef b, bool& flipped) {
  if (b < a) std::swap(a, b);
  flipped = a.neg;
  if (flipped) {
    a.neg = !a.neg;
    b.neg = !b.neg;
  }
  return Pair{a, b};
}

// Position of the pair in a node's operands, as (i, j) with flipped, or i = -1.
std::pair<int, int> find_pair(const std::vector<SRef>& args, const Pair& pair, bool& flipped) {
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i].id != pair.first.id && args[i].id != pair.second.id) continue;
    for (size_t j = i + 1; j < args.size(); ++j) {
      bool f;
      if (canonical(args[i], args[j], f) == pair) {
        flipped = f;
        return {static_cast<int>(i), static_cast<int>(j)};
      }
    }
  }
  return {-1, -1};
}

}  // namespace

void Program::extract_common_pairs(const std::vector<SRef>& roots) {
  extract_pass(Kind::mul, roots);
  extract_pass(Kind::add, roots);
}

// Repeatedly finds the pair of operands that occurs in the most sums (products) and turns
// it into a node of its own. For sums, a pair and its negation count as one: (a - b)
// shares with (b - a). Lazy greedy: candidate counts live in an ordered set and are
// re-verified when taken, so each step costs about the size of the nodes it touches.
// Deterministic: ties go to the smallest pair.
void Program::extract_pass(Kind kind, const std::vector<SRef>& roots) {
  std::vector<int> containers;
  for (int id : schedule(roots))
    if (nodes_[id].kind == kind && nodes_[id].args.size() >= 2) containers.push_back(id);
  std::map<Pair, std::vector<int>> index;  // pair -> nodes that (may) contain it
  for (int id : containers) {
    const auto& a = nodes_[id].args;
    for (size_t i = 0; i < a.size(); ++i)
      for (size_t j = i + 1; j < a.size(); ++j) {
        bool flipped;
        auto& list = index[canonical(a[i], a[j], flipped)];
        if (list.empty() || list.back() != id) list.push_back(id);
      }
  }
  std::set<std::pair<int, Pair>> queue;  // (-count, pair)
  for (const auto& [pair, list] : index)
    if (list.size() >= 2) queue.insert({-static_cast<int>(list.size()), pair});

  while (!queue.empty()) {
    const auto [neg_count, pair] = *queue.begin();
    queue.erase(queue.begin());
    // Verify: which of the listed nodes still hold the pair?
    auto& list = index[pair];
    std::vector<int> holders;
    for (int id : list) {
      bool flipped;
      if (find_pair(nodes_[id].args, pair, flipped).first >= 0) holders.push_back(id);
    }
    list = holders;
    if (static_cast<int>(holders.size()) < 2) continue;
    if (static_cast<int>(holders.size()) < -neg_count) {
      queue.insert({-static_cast<int>(holders.size()), pair});
      continue;
    }
    const SRef shared =
        kind == Kind::add ? add({pair.first, pair.second}) : mul({pair.first, pair.second});
    std::set<Pair> touched;
    for (int id : holders) {
      if (id == shared.id) continue;
      auto& args = nodes_[id].args;
      bool flipped = false;
      const auto [i, j] = find_pair(args, pair, flipped);
      SRef repl = shared;
      repl.neg ^= flipped;
      args.erase(args.begin() + j);
      args.erase(args.begin() + i);
      // New pairs of the replacement with the remaining operands.
      for (const SRef& x : args) {
        bool f;
        const Pair p = canonical(repl, x, f);
        auto& l = index[p];
        if (l.empty() || l.back() != id) l.push_back(id);
        touched.insert(p);
      }
      args.push_back(repl);
    }
    list.clear();
    for (const Pair& p : touched)
      if (index[p].size() >= 2) queue.insert({-static_cast<int>(index[p].size()), p});
  }
}

std::vector<int> Program::schedule(const std::vector<SRef>& roots) const {
  std::vector<int> order;
  std::vector<char> state(nodes_.size(), 0);  // 0 new, 1 on stack, 2 done
  std::vector<std::pair<int, size_t>> stack;
  for (const SRef& r : roots) {
    if (r.id < 0 || state[r.id]) continue;
    stack.push_back({r.id, 0});
    state[r.id] = 1;
    while (!stack.empty()) {
      auto& [id, next] = stack.back();
      const auto& args = nodes_[id].args;
      if (next < args.size()) {
        const int child = args[next++].id;
        if (child >= 0 && !state[child]) {
          state[child] = 1;
          stack.push_back({child, 0});
        }
      } else {
        state[id] = 2;
        order.push_back(id);
        stack.pop_back();
      }
    }
  }
  return order;
}

OpCounts Program::count(const std::vector<SRef>& roots) const {
  OpCounts c;
  for (int id : schedule(roots)) {
    const Node& n = nodes_[id];
    switch (n.kind) {
      case Kind::add:
        c.adds += static_cast<int>(n.args.size()) - 1;
        // A sum of only negated terms starts with a negation.
        if (std::all_of(n.args.begin(), n.args.end(), [](const SRef& a) { return a.neg; }))
          c.adds += 1;
        break;
      case Kind::mul:
        c.muls += static_cast<int>(n.args.size()) - 1;
        break;
      case Kind::div:
        c.divs += 1;
        break;
      case Kind::pow:
        c.muls += static_cast<int>(n.value) - 1;
        break;
      case Kind::sin:
      case Kind::cos:
        c.trig += 1;
        break;
      case Kind::tanh:
      case Kind::exp:
        c.functions += 1;
        break;
      default:
        break;
    }
  }
  // A negated result costs a negation where it is stored.
  for (const SRef& r : roots)
    if (r.id >= 0 && r.neg) c.adds += 1;
  return c;
}

std::vector<double> Program::evaluate(
    const std::vector<SRef>& roots,
    const std::function<double(const std::string&, int)>& input_value) const {
  return evaluate(schedule(roots), roots, input_value);
}

std::vector<double> Program::evaluate(
    const std::vector<int>& order, const std::vector<SRef>& roots,
    const std::function<double(const std::string&, int)>& input_value) const {
  std::vector<double> v(nodes_.size(), 0.0);
  auto value = [&](const SRef& r) { return r.id < 0 ? 0.0 : (r.neg ? -v[r.id] : v[r.id]); };
  for (int id : order) {
    const Node& n = nodes_[id];
    double x = 0;
    switch (n.kind) {
      case Kind::input:
        x = input_value(n.text, n.index);
        break;
      case Kind::constant:
        x = n.value;
        break;
      case Kind::add:
        for (const SRef& a : n.args) x += value(a);
        break;
      case Kind::mul:
        x = 1;
        for (const SRef& a : n.args) x *= value(a);
        break;
      case Kind::div:
        x = value(n.args[0]) / value(n.args[1]);
        break;
      case Kind::sin:
        x = std::sin(value(n.args[0]));
        break;
      case Kind::cos:
        x = std::cos(value(n.args[0]));
        break;
      case Kind::pow:
        x = std::pow(value(n.args[0]), n.value);
        break;
      case Kind::tanh:
        x = std::tanh(value(n.args[0]));
        break;
      case Kind::exp:
        x = std::exp(value(n.args[0]));
        break;
    }
    v[id] = x;
  }
  std::vector<double> out;
  for (const SRef& r : roots) out.push_back(value(r));
  return out;
}

}  // namespace spacearm
