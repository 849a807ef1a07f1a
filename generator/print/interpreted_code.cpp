#include "interpreted_code.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "cpp_printer.hpp"

namespace spacearm {

namespace {

using Op = InterpretedFunction::Op;

// A function's code over virtual registers (one per value), before registers are allocated.
// Hand-written: the statements are the printer's own small subset of C++ (cpp_printer.cpp), and
// a parser of C++ would bring a compiler's front end for a dozen forms.
class CodeBuilder {
 public:
  CodeBuilder(std::string name, const std::vector<std::string>& inputs,
              const std::vector<int>& input_sizes, int num_params)
      : name_(std::move(name)), input_names_(inputs), input_sizes_(input_sizes) {
    for (int i = 0; i < num_params; ++i) params_.push_back(new_value(Kind::parameter));
    for (int size : input_sizes) {
      inputs_.emplace_back();
      for (int i = 0; i < size; ++i) inputs_.back().push_back(new_value(Kind::input));
    }
  }

  // Every statement of a body ("const T t3 = ...;", "out[0][2] = ...;", a sincos_batch call).
  void statements(std::string_view body) {
    for (size_t start = 0, end; start < body.size(); start = end + 1) {
      end = body.find(';', start);
      if (end == std::string_view::npos) end = body.size();
      statement(trimmed(body.substr(start, end - start)));
    }
  }
  // A value read as the result entry out[k][0] (the range checks' values).
  void result_value(int k, std::string_view expression) {
    text_ = expression, at_ = 0;
    const int v = expr();
    expect_end();
    store(k, 0, v);
  }

  InterpretedFunction finish(const std::vector<int>& result_sizes);

 private:
  enum class Kind { constant, parameter, input, computed };
  struct VInstruction {
    Op op;
    int dst, a, b;  // virtual registers (store: result, entry, value; sincos4: -, operands, count)
  };
  std::string name_;
  std::vector<std::string> input_names_;
  std::vector<int> input_sizes_;
  std::vector<Kind> kinds_;
  std::vector<double> constant_of_;         // per value (constants only)
  std::map<std::uint64_t, int> constants_;  // by bits
  std::vector<int> params_;
  std::vector<std::vector<int>> inputs_;
  std::map<std::string, int, std::less<>> named_;  // t3, w[2], out[0][5], sines1[3], ...
  std::map<std::string, std::vector<int>, std::less<>> angle_lists_;
  std::vector<VInstruction> code_;
  std::vector<int> operands_;
  std::string_view text_;  // the statement being read
  size_t at_ = 0;

  int new_value(Kind kind) {
    kinds_.push_back(kind);
    constant_of_.push_back(0);
    return static_cast<int>(kinds_.size()) - 1;
  }
  int constant(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const auto [it, added] = constants_.emplace(bits, 0);
    if (added) it->second = new_value(Kind::constant), constant_of_[it->second] = v;
    return it->second;
  }
  int emit(Op op, int a, int b = -1) {
    const int dst = new_value(Kind::computed);
    code_.push_back({op, dst, a, b});
    return dst;
  }
  void store(int k, int entry, int v) {
    code_.push_back({Op::store, k, entry, v});
    named_["out[" + std::to_string(k) + "][" + std::to_string(entry) + "]"] = v;
  }

  [[noreturn]] void fail(const std::string& why) const {
    throw std::logic_error("interpreted_code: function " + name_ + ": " + why + " in '" +
                           std::string(text_) + "'");
  }
  static std::string_view trimmed(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  }
  static bool starts(std::string_view s, std::string_view prefix) {
    return s.substr(0, prefix.size()) == prefix;
  }

  void statement(std::string_view s);
  void sincos_call(std::string_view s);
  void fold_negations();

  // The cursor over text_.
  void skip_spaces() {
    while (at_ < text_.size() && text_[at_] == ' ') ++at_;
  }
  bool accept(char c) {
    skip_spaces();
    if (at_ < text_.size() && text_[at_] == c) return ++at_, true;
    return false;
  }
  void expect(char c) {
    if (!accept(c)) fail(std::string("expected '") + c + "'");
  }
  void expect_end() {
    skip_spaces();
    if (at_ != text_.size()) fail("unexpected text at " + std::to_string(at_));
  }
  std::string_view identifier() {
    skip_spaces();
    const size_t start = at_;
    while (at_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_'))
      ++at_;
    return text_.substr(start, at_ - start);
  }
  int index() {
    expect('[');
    skip_spaces();
    int i = 0;
    const size_t start = at_;
    while (at_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[at_])))
      i = 10 * i + (text_[at_++] - '0');
    if (at_ == start || at_ - start > 9) fail("expected an index");
    expect(']');
    return i;
  }
  // C's grammar of these operators: sums of products of unary terms, all left-associative.
  int expr() {
    int v = term();
    for (;;) {
      if (accept('+'))
        v = emit(Op::add, v, term());
      else if (accept('-'))
        v = emit(Op::sub, v, term());
      else
        return v;
    }
  }
  int term() {
    int v = unary();
    for (;;) {
      if (accept('*'))
        v = emit(Op::mul, v, unary());
      else if (accept('/'))
        v = emit(Op::div, v, unary());
      else
        return v;
    }
  }
  int unary() {
    if (accept('-')) return emit(Op::neg, unary());
    return primary();
  }
  int primary();
  int literal();
  int element(std::string_view name);
};

int CodeBuilder::literal() {
  skip_spaces();
  const size_t close = text_.find(')', at_);
  if (close == std::string_view::npos) fail("unclosed literal");
  const std::string digits(trimmed(text_.substr(at_, close - at_)));
  char* end = nullptr;
  const double v =
      std::strtod(digits.c_str(), &end);  // correctly rounded, as the compiler reads it
  if (digits.empty() || end != digits.c_str() + digits.size()) fail("bad literal " + digits);
  at_ = close + 1;
  return constant(v);
}

int CodeBuilder::primary() {
  if (accept('(')) {
    const int v = expr();
    expect(')');
    return v;
  }
  const std::string_view name = identifier();
  if (name.empty()) fail("expected a value at " + std::to_string(at_));
  if (name == "T") {
    expect('(');
    return literal();
  }
  static const std::map<std::string_view, Op> functions = {
      {"tanh", Op::tanh}, {"exp", Op::exp}, {"sin", Op::sin}, {"cos", Op::cos}, {"pow", Op::pow}};
  if (const auto f = functions.find(name); f != functions.end()) {
    expect('(');
    const int x = expr();
    if (f->second != Op::pow) {
      expect(')');
      return emit(f->second, x);
    }
    expect(',');
    skip_spaces();
    const size_t start = at_;
    while (at_ < text_.size() && text_[at_] != ')') ++at_;
    const std::string digits(trimmed(text_.substr(start, at_ - start)));
    expect(')');
    return emit(Op::pow, x, constant(std::stod(digits)));  // pow(double, int) takes a double
  }
  return element(name);
}

// A named value: a temporary, an input's or parameter's entry, an entry already stored, a sine.
int CodeBuilder::element(std::string_view name) {
  skip_spaces();
  if (at_ >= text_.size() || text_[at_] != '[') {
    const auto it = named_.find(name);
    if (it == named_.end()) fail("unknown name " + std::string(name));
    return it->second;
  }
  const int i = index();
  if (name == "params") {
    if (i >= static_cast<int>(params_.size())) fail("parameter index out of range");
    return params_[i];
  }
  for (size_t k = 0; k < input_names_.size(); ++k)
    if (name == input_names_[k]) {
      if (i >= input_sizes_[k]) fail("input index out of range");
      return inputs_[k][i];
    }
  std::string key = std::string(name) + "[" + std::to_string(i) + "]";
  if (name == "out") key += "[" + std::to_string(index()) + "]";
  const auto it = named_.find(key);
  if (it == named_.end()) fail("unknown entry " + key);
  return it->second;
}

void CodeBuilder::statement(std::string_view s) {
  text_ = s, at_ = 0;
  if (s.empty() || starts(s, "using ") || starts(s, "T sines")) return;
  if (starts(s, "sincos_batch(")) return sincos_call(s);
  if (starts(s, "return ")) fail("a body that returns its value");
  const bool constant_t = starts(s, "const T ");
  if (constant_t) at_ = 8;
  const std::string_view name = identifier();
  if (starts(name, "angles")) {  // const T anglesN[K] = {a, b, ...}
    index();
    expect('='), expect('{');
    std::vector<int>& list = angle_lists_[std::string(name)];
    do list.push_back(expr());
    while (accept(','));
    expect('}');
    return expect_end();
  }
  if (name == "out") {
    const int k = index(), entry = index();
    expect('=');
    const int v = expr();
    expect_end();
    return store(k, entry, v);
  }
  std::string key(name);
  if (!constant_t) key += "[" + std::to_string(index()) + "]";  // a work array's slot, w[i]
  expect('=');
  const int v = expr();
  expect_end();
  named_[key] = v;
}

// sincos_batch(anglesN, sinesN, cosinesN): four angles per call, as the printed helper takes them.
void CodeBuilder::sincos_call(std::string_view) {  // text_ holds it
  at_ = std::strlen("sincos_batch(");
  const std::string angles(identifier());
  expect(',');
  const std::string sines(identifier());
  expect(',');
  const std::string cosines(identifier());
  expect(')');
  expect_end();
  const auto list = angle_lists_.find(angles);
  if (list == angle_lists_.end()) fail("unknown angles " + angles);
  const std::vector<int>& a = list->second;
  for (size_t i = 0; i < a.size(); i += 4) {
    const int count = static_cast<int>(std::min<size_t>(4, a.size() - i));
    const int at = static_cast<int>(operands_.size());
    operands_.resize(operands_.size() + 12, -1);
    for (int j = 0; j < count; ++j) {
      const std::string entry = "[" + std::to_string(i + j) + "]";
      operands_[at + j] = a[i + j];
      operands_[at + 4 + j] = named_[sines + entry] = new_value(Kind::computed);
      operands_[at + 8 + j] = named_[cosines + entry] = new_value(Kind::computed);
    }
    code_.push_back({Op::sincos4, -1, at, count});
  }
}

// a + (-b) is a - b, a - (-b) is a + b and (-a) + b is b - a, exactly (IEEE 754 defines
// subtraction as the addition of the negation, and addition commutes): a negation read once, by
// a sum, is folded into it, and operations whose values no one reads are dropped (as a compiler
// drops them). Fewer operations to dispatch; the same numbers.
void CodeBuilder::fold_negations() {
  std::vector<int> uses(kinds_.size(), 0), defined_by(kinds_.size(), -1);
  for (size_t k = 0; k < code_.size(); ++k) {
    const VInstruction& i = code_[k];
    if (i.op == Op::store) {
      ++uses[i.b];
    } else if (i.op == Op::sincos4) {
      for (int j = 0; j < i.b; ++j) ++uses[operands_[i.a + j]];
    } else {
      defined_by[i.dst] = static_cast<int>(k);
      ++uses[i.a];
      if (i.b >= 0) ++uses[i.b];
    }
  }
  const auto single_negation = [&](int v) {
    return defined_by[v] >= 0 && code_[defined_by[v]].op == Op::neg && uses[v] == 1;
  };
  for (VInstruction& i : code_) {
    if (i.op != Op::add && i.op != Op::sub) continue;
    // The sum now reads the negated value itself: one more use of it, one fewer of the
    // negation (whose own read of it goes when it is dropped as dead below).
    if (single_negation(i.b)) {
      --uses[i.b];
      i.b = code_[defined_by[i.b]].a;
      ++uses[i.b];
      i.op = i.op == Op::add ? Op::sub : Op::add;
    } else if (i.op == Op::add && single_negation(i.a)) {
      --uses[i.a];
      i.a = std::exchange(i.b, code_[defined_by[i.a]].a);
      ++uses[i.b];
      i.op = Op::sub;
    }
  }
  // Dead values, last reader first (a value read only by a dead one is dead too).
  std::vector<bool> dead(code_.size(), false);
  for (size_t k = code_.size(); k-- > 0;) {
    const VInstruction& i = code_[k];
    if (i.op == Op::store || i.op == Op::sincos4 || uses[i.dst] > 0) continue;
    dead[k] = true;
    --uses[i.a];
    if (i.b >= 0) --uses[i.b];
  }
  std::vector<VInstruction> kept;
  for (size_t k = 0; k < code_.size(); ++k)
    if (!dead[k]) kept.push_back(code_[k]);
  code_.swap(kept);
}

// Registers: the fixed ones (constants, parameters, inputs), then each computed value in a
// register freed by a value no later instruction reads (linear scan over straight-line code).
InterpretedFunction CodeBuilder::finish(const std::vector<int>& result_sizes) {
  InterpretedFunction f;
  f.name = name_;
  f.num_params = static_cast<int>(params_.size());
  f.input_sizes = input_sizes_;
  f.result_sizes = result_sizes;
  std::vector<int> reg(kinds_.size(), -1);
  for (const auto& [bits, v] : constants_) {
    reg[v] = static_cast<int>(f.constants.size());
    f.constants.push_back(constant_of_[v]);
  }
  int next = static_cast<int>(f.constants.size());
  for (int v : params_) reg[v] = next++;
  for (const auto& input : inputs_)
    for (int v : input) reg[v] = next++;
  fold_negations();
  // The last instruction that reads each value.
  std::vector<int> last(kinds_.size(), -1);
  const auto reads = [&](const VInstruction& i, auto&& use) {
    if (i.op == Op::store) return use(i.b);
    if (i.op == Op::sincos4) {
      for (int j = 0; j < i.b; ++j) use(operands_[i.a + j]);
      return;
    }
    use(i.a);
    if (i.op == Op::add || i.op == Op::sub || i.op == Op::mul || i.op == Op::div || i.op == Op::pow)
      use(i.b);
  };
  for (size_t k = 0; k < code_.size(); ++k)
    reads(code_[k], [&](int v) { last[v] = static_cast<int>(k); });
  std::vector<int> free;
  int top = next;
  const auto allocate = [&](int v) {
    if (free.empty()) return reg[v] = top++;
    reg[v] = free.back();
    free.pop_back();
    return reg[v];
  };
  for (size_t k = 0; k < code_.size(); ++k) {
    VInstruction i = code_[k];
    // Operands read here for the last time free their registers before the result takes one:
    // every operation reads all its operands before it writes.
    std::vector<int> done;
    reads(i, [&](int v) {
      if (kinds_[v] == Kind::computed && last[v] == static_cast<int>(k) && reg[v] >= 0)
        done.push_back(v);
    });
    std::vector<int> mapped;
    reads(i, [&](int v) { mapped.push_back(reg[v]); });
    for (int v : done)
      if (reg[v] >= 0) free.push_back(reg[v]), reg[v] = -2;  // -2: freed (each once)
    if (i.op == Op::store) {
      f.code.push_back({Op::store, i.dst, i.a, mapped[0]});
    } else if (i.op == Op::sincos4) {
      for (int j = 0; j < i.b; ++j) {
        operands_[i.a + j] = mapped[j];
        for (int half : {4, 8}) {
          const int v = operands_[i.a + half + j];
          operands_[i.a + half + j] = allocate(v);
          if (last[v] < 0) free.push_back(reg[v]);  // a sine no one reads
        }
      }
      f.code.push_back({Op::sincos4, -1, i.a, i.b});
    } else {
      const int dst = allocate(i.dst);
      f.code.push_back({i.op, dst, mapped[0], mapped.size() > 1 ? mapped[1] : -1});
      if (last[i.dst] < 0) free.push_back(dst);
    }
  }
  f.operands = operands_;
  f.num_registers = top;
  return f;
}

}  // namespace

InterpretedFunction interpreted_statements(const std::string& name,
                                           const std::vector<std::string>& inputs,
                                           const std::vector<int>& input_sizes, int num_params,
                                           const std::string& body,
                                           const std::vector<int>& result_sizes) {
  CodeBuilder builder(name, inputs, input_sizes, num_params);
  builder.statements(body);
  return builder.finish(result_sizes);
}

InterpretedModel interpreted_code(const LoweredModel& model) {
  const ModelFacts& facts = model.facts;
  const int num_params = static_cast<int>(facts.parameter_names.size());
  InterpretedModel result;
  for (const FunctionSpec& f : model.functions) {
    std::vector<std::string> names;
    std::vector<int> sizes, result_sizes;
    for (const ArraySpec& a : f.inputs)
      names.push_back(a.name), sizes.push_back(facts.dims(a.rows) * facts.dims(a.cols));
    for (const ArraySpec& r : f.results)
      result_sizes.push_back(facts.dims(r.rows) * facts.dims(r.cols));
    CodeBuilder builder(f.name, names, sizes, num_params);
    builder.statements(c_body_statements(f, facts.dims));
    result.functions.push_back(builder.finish(result_sizes));
    result.functions.back().lanes = f.lanes;
  }
  const std::vector<std::string> checks = c_check_values(facts);
  CodeBuilder builder("parameter_error", {}, {}, num_params);
  for (size_t k = 0; k < checks.size(); ++k) builder.result_value(static_cast<int>(k), checks[k]);
  result.check_values = builder.finish(std::vector<int>(checks.size(), 1));
  return result;
}

}  // namespace spacearm
