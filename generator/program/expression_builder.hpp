// GiNaC expressions become nodes of a straight-line program. The Horner builder writes each
// expression as a multivariate Horner scheme in its "variables": symbols whose nodes are built
// on first use, which a model kind declares (the planar chain's sin/cos of body angles and its
// body rates, planar_expressions.hpp); run-time parameters and numbers are coefficients, and
// tanh and exp calls become variables of their own. The plain builder is the benchmarks'
// baseline: GiNaC's expanded expression node by node.
#pragma once

#include <ginac/ginac.h>

#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "straight_line.hpp"

namespace spacearm {

class ExpressionBuilder {
 public:
  virtual ~ExpressionBuilder() = default;
  // The program the nodes are built in.
  virtual Program& program() = 0;
  // The node of an expression in the closed forms' symbols.
  virtual SRef build(const GiNaC::ex& e) = 0;
  // Makes `symbol` a variable whose value is an existing node (the solved qdd of a composed
  // output, which the state Jacobian's expressions then use).
  virtual void bind(const GiNaC::ex& symbol, SRef node) = 0;
};

// The symbols of the input arrays q, qd and params, in their order.
struct InputSymbols {
  std::vector<GiNaC::symbol> q, qd, parameters;
};

class HornerBuilder : public ExpressionBuilder {
 public:
  explicit HornerBuilder(InputSymbols inputs);
  Program& program() override { return prog_; }
  SRef build(const GiNaC::ex& e) override;
  void bind(const GiNaC::ex& symbol, SRef node) override;

 protected:
  // A variable whose node `node` builds on first use. The order of declaration breaks the
  // Horner scheme's ties, so a kind declares its variables in a fixed order.
  void add_variable(const GiNaC::ex& symbol, std::function<SRef()> node);
  // Substitutions made before expansion: calls by their atoms (cos(theta_1) -> c1), then, in
  // another velocity basis, velocities by that basis.
  void substitute_atom(const GiNaC::ex& call, const GiNaC::ex& atom);
  void substitute_velocity(const GiNaC::ex& qd, const GiNaC::ex& basis);
  // The node of an expression of variables, inputs, parameters and numbers, without factoring.
  SRef node_of(const GiNaC::ex& e);
  const InputSymbols& inputs() const { return inputs_; }

 private:
  struct Term {
    GiNaC::ex coeff;                        // numeric or an expression of run-time parameters
    std::vector<std::pair<int, int>> mono;  // (variable, exponent > 0), sorted by variable
  };
  GiNaC::ex function_atoms(const GiNaC::ex& e);
  SRef variable_node(int v);
  bool is_variable(const GiNaC::ex& e) const { return variable_index_.count(e) != 0; }
  bool has_variable(const GiNaC::ex& e) const;
  SRef integer_power(SRef x, int k);
  std::vector<Term> terms_of(const GiNaC::ex& e);
  SRef leaf(const Term& t);
  SRef horner(const std::vector<Term>& terms);

  Program prog_;
  InputSymbols inputs_;
  std::map<GiNaC::ex, int, GiNaC::ex_is_less> variable_index_, parameter_index_;
  std::vector<std::function<SRef()>> variable_builders_;
  std::map<int, SRef> variable_nodes_;
  GiNaC::exmap atom_subs_, velocity_subs_, function_subs_;
};

// The unoptimized baseline: nothing shared, a sin/cos call per occurrence, pow for powers (what
// SymPy's ccode without cse gives); its program does no hash-consing.
std::unique_ptr<ExpressionBuilder> plain_builder(const InputSymbols& inputs);

}  // namespace spacearm
