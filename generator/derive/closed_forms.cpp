#include "closed_forms.hpp"

#include <cmath>
#include <stdexcept>

namespace spacearm {

using GiNaC::ex;
using GiNaC::lst;
using GiNaC::numeric;

const GiNaC::matrix& ClosedForms::expression(Output output) const {
  auto it = outputs.find(output);
  if (it == outputs.end())
    throw std::invalid_argument("the model has no " + to_string(output) + " (not derived)");
  return it->second;
}

double evaluate(const ClosedForms& model, const GiNaC::ex& e, const std::vector<double>& q,
                const std::vector<double>& qd, const std::vector<double>& params) {
  lst subs;
  // Doubles are converted exactly to rationals so the evaluation itself adds no rounding.
  auto exact = [](double v) {
    int exponent = 0;
    const double mantissa = std::frexp(v, &exponent);  // v = mantissa 2^exponent
    const long integer = static_cast<long>(std::ldexp(mantissa, 53));
    return GiNaC::numeric(integer) * GiNaC::pow(GiNaC::numeric(2), exponent - 53);
  };
  const int saved_digits = GiNaC::Digits;
  GiNaC::Digits = 40;
  for (int i = 0; i < model.n(); ++i) {
    subs.append(model.q[i] == exact(q.at(i)));
    subs.append(model.qd[i] == exact(qd.at(i)));
  }
  for (size_t i = 0; i < model.parameters.size(); ++i)
    subs.append(model.parameters[i] ==
                exact(params.empty() ? model.nominal_parameters.at(i) : params.at(i)));
  const ex value = GiNaC::evalf(e.subs(subs));
  GiNaC::Digits = saved_digits;
  if (!GiNaC::is_a<numeric>(value))
    throw std::runtime_error("expression did not evaluate to a number");
  return GiNaC::ex_to<numeric>(value).to_double();
}

std::vector<double> evaluate(const ClosedForms& model, const GiNaC::matrix& m,
                             const std::vector<double>& q, const std::vector<double>& qd,
                             const std::vector<double>& params) {
  std::vector<double> values;
  for (unsigned i = 0; i < m.rows(); ++i)
    for (unsigned j = 0; j < m.cols(); ++j)
      values.push_back(evaluate(model, m(i, j), q, qd, params));
  return values;
}

std::vector<ex> entries_of(const GiNaC::matrix& m) {
  std::vector<ex> v;
  for (unsigned i = 0; i < m.rows(); ++i)
    for (unsigned j = 0; j < m.cols(); ++j) v.push_back(m(i, j));
  return v;
}

}  // namespace spacearm
