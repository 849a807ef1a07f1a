// The scalars that the recursive algorithms run on, so one templated algorithm serves three
// uses: double (the reference a program is checked against), Sym (recorded into a straight-line
// program, with CSE, operation counts and the printer shared with the closed forms), and Dual
// over either (forward-mode differentiation along one direction). Nothing here knows a chain,
// a body or a scene: a planar or a spatial chain (planar_chain.cpp) is written against these.
#pragma once

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "straight_line.hpp"

namespace spacearm {

// A value recorded in a program, folding what needs no code (zeros, constants, x - x), so the
// algorithms below can be written for plain numbers and run on either.
class Sym {
 public:
  Sym() = default;  // zero
  Sym(Program* p, SRef r) : p_(p), r_(r) {}
  static Sym number(Program* p, double v) { return v == 0 ? Sym() : Sym(p, p->constant(v)); }
  SRef ref() const { return r_; }
  bool is_zero() const { return r_.id < 0; }
  // Whether the value is a constant, and which.
  bool constant(double& v) const {
    if (is_zero()) return (v = 0, true);
    const Program::Node& n = p_->node(r_.id);
    if (n.kind != Program::Kind::constant) return false;
    v = r_.neg ? -n.value : n.value;
    return true;
  }

  friend Sym operator-(const Sym& a) { return a.is_zero() ? a : Sym(a.p_, -a.r_); }
  friend Sym operator+(const Sym& a, const Sym& b) {
    if (a.is_zero()) return b;
    if (b.is_zero()) return a;
    if (a.r_.id == b.r_.id && a.r_.neg != b.r_.neg) return Sym();  // x - x
    double x, y;
    if (a.constant(x) && b.constant(y)) return number(a.p_, x + y);
    return Sym(a.p_, a.p_->add({a.r_, b.r_}));
  }
  friend Sym operator-(const Sym& a, const Sym& b) { return a + (-b); }
  friend Sym operator*(const Sym& a, double k) { return a.is_zero() ? a : a * number(a.p_, k); }
  friend Sym operator*(const Sym& a, const Sym& b) {
    if (a.is_zero() || b.is_zero()) return Sym();
    double x, y;
    if (a.constant(x) && b.constant(y)) return number(a.p_, x * y);
    return Sym(a.p_, a.p_->mul({a.r_, b.r_}));
  }
  friend Sym operator/(const Sym& a, const Sym& b) {
    double y;
    if (b.constant(y)) {
      if (y == 0) throw std::logic_error("recursive dynamics: division by zero");
      return a * number(b.p_, 1 / y);
    }
    if (a.is_zero()) return a;
    return Sym(b.p_, b.p_->div(a.r_, b.r_));
  }
  Sym& operator+=(const Sym& b) { return *this = *this + b; }
  Sym& operator-=(const Sym& b) { return *this = *this - b; }
  friend Sym sin(const Sym& a) { return a.is_zero() ? a : Sym(a.p_, a.p_->sin(a.r_)); }
  friend Sym cos(const Sym& a) {
    if (a.is_zero()) throw std::logic_error("recursive dynamics: cos of a folded zero");
    return Sym(a.p_, a.p_->cos(a.r_));
  }
  friend Sym reciprocal(const Sym& a) {
    if (a.is_zero()) throw std::logic_error("recursive dynamics: division by zero");
    return number(a.p_, 1.0) / a;
  }
  friend Sym tanh(const Sym& a) { return a.is_zero() ? a : Sym(a.p_, a.p_->tanh(a.r_)); }
  friend Sym exp(const Sym& a) { return Sym(a.p_, a.p_->exp(a.r_)); }

 private:
  Program* p_ = nullptr;
  SRef r_;
};

inline double reciprocal(double x) { return 1 / x; }

// Forward-mode differentiation: a value and its derivative along one direction, seeded in the
// inputs. The chain's algorithms run on it unchanged; on Sym, the tangents that are zero fold
// away, so a direction costs only the work that depends on it.
template <class T>
struct Dual {
  T v, d;
  friend Dual operator-(const Dual& a) { return {-a.v, -a.d}; }
  friend Dual operator+(const Dual& a, const Dual& b) { return {a.v + b.v, a.d + b.d}; }
  friend Dual operator-(const Dual& a, const Dual& b) { return {a.v - b.v, a.d - b.d}; }
  friend Dual operator*(const Dual& a, double k) { return {a.v * k, a.d * k}; }
  friend Dual operator*(const Dual& a, const Dual& b) { return {a.v * b.v, a.d * b.v + a.v * b.d}; }
  // One reciprocal per divisor, shared by every direction that divides by it.
  friend Dual operator/(const Dual& a, const Dual& b) {
    const T r = reciprocal(b.v), q = a.v * r;
    return {q, (a.d - q * b.d) * r};
  }
  Dual& operator+=(const Dual& b) { return *this = *this + b; }
  Dual& operator-=(const Dual& b) { return *this = *this - b; }
  friend Dual sin(const Dual& a) {
    using std::cos;
    using std::sin;
    return {sin(a.v), cos(a.v) * a.d};
  }
  friend Dual cos(const Dual& a) {
    using std::cos;
    using std::sin;
    return {cos(a.v), -(sin(a.v) * a.d)};
  }
  friend Dual tanh(const Dual& a) {
    using std::tanh;
    const T t = tanh(a.v);
    return {t, a.d - t * t * a.d};
  }
  friend Dual exp(const Dual& a) {
    using std::exp;
    const T e = exp(a.v);
    return {e, e * a.d};
  }
};

// Where the algorithms get their numbers: input arrays by name and literals.
template <class T>
struct Values {
  std::function<T(const std::string&, int)> input;
  std::function<T(double)> number;
};

// The inputs as duals, each with the tangent seed(array, i) (T{} where it has none).
template <class T>
Values<Dual<T>> seeded(const Values<T>& values,
                       const std::function<T(const std::string&, int)>& seed) {
  return {[values, seed](const std::string& a, int i) {
            return Dual<T>{values.input(a, i), seed(a, i)};
          },
          [values](double v) {
            return Dual<T>{values.number(v), T{}};
          }};
}
// The tangents of a dual vector.
template <class T>
std::vector<T> tangents(const std::vector<Dual<T>>& x) {
  std::vector<T> d;
  for (const Dual<T>& y : x) d.push_back(y.d);
  return d;
}

}  // namespace spacearm
