#include "program_expression.hpp"

#include <cstdio>
#include <cstdlib>
#include <unordered_map>

namespace spacearm {

namespace {

size_t terms(const GiNaC::ex& e) { return GiNaC::is_a<GiNaC::add>(e) ? e.nops() : 1; }

// A recorded double as the shortest decimal that reads back as it (0.05, not GiNaC's exact
// binary value 0.050000000000000002776), a float of GiNaC's precision.
GiNaC::ex shortest_decimal(double v) {
  char text[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, v);
    if (std::strtod(text, nullptr) == v) break;
  }
  return GiNaC::numeric(text);
}

// Each float of an expression as the shortest decimal of its nearest double: what the
// generated code's arithmetic in double gives, without the long floats' trailing digits
// (1.6, not 1.5999999999999999999).
struct ShortestFloats : GiNaC::map_function {
  GiNaC::ex operator()(const GiNaC::ex& e) override {
    if (GiNaC::is_a<GiNaC::numeric>(e) && !GiNaC::ex_to<GiNaC::numeric>(e).is_rational())
      return shortest_decimal(GiNaC::ex_to<GiNaC::numeric>(e).to_double());
    return e.map(*this);
  }
};

}  // namespace

std::optional<GiNaC::ex> expanded_expression(
    const Program& program, SRef root,
    const std::function<GiNaC::ex(const std::string&, int)>& symbol, size_t max_terms) {
  if (root.id < 0) return GiNaC::ex(0);
  std::unordered_map<int, GiNaC::ex> value;
  auto of = [&value](const SRef& r) {
    return r.id < 0 ? GiNaC::ex(0) : r.neg ? -value.at(r.id) : value.at(r.id);
  };
  using Kind = Program::Kind;
  for (int id : program.schedule({root})) {
    const Program::Node& n = program.node(id);
    GiNaC::ex x;
    switch (n.kind) {
      case Kind::input:
        x = symbol(n.text, n.index);
        break;
      case Kind::constant:
        x = shortest_decimal(n.value);
        break;
      case Kind::add: {
        size_t count = 0;
        for (const SRef& a : n.args) {
          count += terms(of(a));
          x += of(a);
        }
        if (count > 2 * max_terms) return std::nullopt;
        break;
      }
      case Kind::mul: {
        x = 1;
        size_t product = 1;
        for (const SRef& a : n.args) {
          product *= terms(of(a));
          if (product > max_terms) return std::nullopt;
          x *= of(a);
        }
        break;
      }
      case Kind::div:
        x = of(n.args[0]) / of(n.args[1]);
        break;
      case Kind::sin:
        x = GiNaC::sin(of(n.args[0]));
        break;
      case Kind::cos:
        x = GiNaC::cos(of(n.args[0]));
        break;
      case Kind::pow:
        x = GiNaC::pow(of(n.args[0]), static_cast<int>(n.value));
        break;
      case Kind::tanh:
        x = GiNaC::tanh(of(n.args[0]));
        break;
      case Kind::exp:
        x = GiNaC::exp(of(n.args[0]));
        break;
    }
    x = x.expand();
    if (terms(x) > max_terms) return std::nullopt;
    value[id] = x;
  }
  ShortestFloats shortest;
  return shortest(of(root));
}

}  // namespace spacearm
