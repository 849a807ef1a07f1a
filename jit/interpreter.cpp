#include "interpreter.hpp"

#include <cmath>
#include <cstring>
#include <vector>

namespace spacearm {

namespace {

using Op = InterpretedFunction::Op;

#if SPACEARM_JIT_VECTOR_TRIG && defined(__x86_64__) && defined(__GLIBC__)
// libmvec's sin and cos of four angles, declared as the generated code declares them
// (cpp_printer.cpp, kTrigBatchIncludes), called only where the CPU has AVX2 and FMA.
typedef double Double4 __attribute__((vector_size(32)));
extern "C" [[gnu::target("avx2,fma")]] Double4 _ZGVdN4v_sin(Double4);
extern "C" [[gnu::target("avx2,fma")]] Double4 _ZGVdN4v_cos(Double4);

[[gnu::target("avx2,fma")]] void sincos4(const double* angle, double* s, double* c) {
  Double4 a;
  std::memcpy(&a, angle, sizeof a);
  const Double4 sines = _ZGVdN4v_sin(a), cosines = _ZGVdN4v_cos(a);
  std::memcpy(s, &sines, sizeof sines);
  std::memcpy(c, &cosines, sizeof cosines);
}
bool vector_trig_runs() {
  static const bool runs = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return runs;
}
#else
void sincos4(const double*, double*, double*) {}
bool vector_trig_runs() { return false; }
#endif

// sin and cos of four angles (zero where fewer are given), as the compiled sincos_batch computes
// them: each lane's value depends on its own angle alone, in libmvec and in libm.
void sin_cos(TrigSource trig, const double (&angle)[4], double (&s)[4], double (&c)[4]) {
  if (trig.vector_trig && vector_trig_runs()) return sincos4(angle, s, c);
  for (int j = 0; j < 4; ++j) s[j] = std::sin(angle[j]), c[j] = std::cos(angle[j]);
}

// Each thread's register file, grown to the largest function it has run (never empty).
double* registers(size_t count) {
  thread_local std::vector<double> file(1);
  if (file.size() < count) file.resize(count);
  return file.data();
}

// n doubles (none: a model without parameters passes no array).
void copy(double* to, const double* from, size_t n) {
  if (n > 0) std::memcpy(to, from, n * sizeof(double));
}

}  // namespace

void interpret(const InterpretedFunction& f, TrigSource trig, const double* const* in,
               const double* params, double* const* out) {
  double* r = registers(f.num_registers);
  // The fixed registers: constants, parameters, inputs.
  copy(r, f.constants.data(), f.constants.size());
  copy(r + f.constants.size(), params, f.num_params);
  double* at = r + f.first_input_register();
  for (size_t k = 0; k < f.input_sizes.size(); ++k)
    copy(at, in[k], f.input_sizes[k]), at += f.input_sizes[k];
  // Threaded dispatch (GCC's labels as values): one indirect jump per operation, each predicted
  // from its own site, instead of a switch's single jump.
  static const void* const kLabels[] = {&&add, &&sub, &&mul, &&div, &&neg,     &&tanh,
                                        &&exp, &&pow, &&sin, &&cos, &&sincos4, &&store};
  static_assert(sizeof kLabels / sizeof *kLabels == static_cast<int>(Op::store) + 1);
  const std::int32_t* operands = f.operands.data();
  const InterpretedFunction::Instruction* i = f.code.data();
  const InterpretedFunction::Instruction* const end = i + f.code.size();
#define SPACEARM_NEXT     \
  if (++i == end) return; \
  goto* kLabels[static_cast<int>(i->op)]
  if (i == end) return;
  goto* kLabels[static_cast<int>(i->op)];
add:
  r[i->dst] = r[i->a] + r[i->b];
  SPACEARM_NEXT;
sub:
  r[i->dst] = r[i->a] - r[i->b];
  SPACEARM_NEXT;
mul:
  r[i->dst] = r[i->a] * r[i->b];
  SPACEARM_NEXT;
div:
  r[i->dst] = r[i->a] / r[i->b];
  SPACEARM_NEXT;
neg:
  r[i->dst] = -r[i->a];
  SPACEARM_NEXT;
tanh:
  r[i->dst] = std::tanh(r[i->a]);
  SPACEARM_NEXT;
exp:
  r[i->dst] = std::exp(r[i->a]);
  SPACEARM_NEXT;
pow:
  r[i->dst] = std::pow(r[i->a], r[i->b]);
  SPACEARM_NEXT;
sin:
  r[i->dst] = std::sin(r[i->a]);
  SPACEARM_NEXT;
cos:
  r[i->dst] = std::cos(r[i->a]);
  SPACEARM_NEXT;
store:
  out[i->dst][i->a] = r[i->b];
  SPACEARM_NEXT;
sincos4 : {
  const std::int32_t* o = operands + i->a;
  double angle[4] = {}, s[4], c[4];
  for (int j = 0; j < i->b; ++j) angle[j] = r[o[j]];
  sin_cos(trig, angle, s, c);
  for (int j = 0; j < i->b; ++j) r[o[4 + j]] = s[j], r[o[8 + j]] = c[j];
}
  SPACEARM_NEXT;
#undef SPACEARM_NEXT
}

void interpret_lanes(const InterpretedFunction& f, TrigSource trig, const double* const* in,
                     const double* params, double* const* out) {
  double* r = registers(4 * static_cast<size_t>(f.num_registers));
  for (size_t k = 0; k < f.constants.size(); ++k)
    for (int l = 0; l < 4; ++l) r[4 * k + l] = f.constants[k];
  copy(r + 4 * f.constants.size(), params, 4 * f.num_params);
  double* at = r + 4 * f.first_input_register();
  for (size_t k = 0; k < f.input_sizes.size(); ++k)
    copy(at, in[k], 4 * f.input_sizes[k]), at += 4 * f.input_sizes[k];
  const std::int32_t* operands = f.operands.data();
  const auto each = [r](const InterpretedFunction::Instruction& i, auto op) {
    double* d = r + 4 * i.dst;
    const double *a = r + 4 * i.a, *b = r + 4 * (i.b < 0 ? 0 : i.b);
    for (int l = 0; l < 4; ++l) d[l] = op(a[l], b[l]);
  };
  for (const InterpretedFunction::Instruction& i : f.code) {
    switch (i.op) {
      case Op::add:
        each(i, [](double a, double b) { return a + b; });
        break;
      case Op::sub:
        each(i, [](double a, double b) { return a - b; });
        break;
      case Op::mul:
        each(i, [](double a, double b) { return a * b; });
        break;
      case Op::div:
        each(i, [](double a, double b) { return a / b; });
        break;
      case Op::neg:
        each(i, [](double a, double) { return -a; });
        break;
      case Op::tanh:
        each(i, [](double a, double) { return std::tanh(a); });
        break;
      case Op::exp:
        each(i, [](double a, double) { return std::exp(a); });
        break;
      case Op::pow:
        each(i, [](double a, double b) { return std::pow(a, b); });
        break;
      case Op::sin:
        each(i, [](double a, double) { return std::sin(a); });
        break;
      case Op::cos:
        each(i, [](double a, double) { return std::cos(a); });
        break;
      case Op::store:
        for (int l = 0; l < 4; ++l) out[i.dst][4 * i.a + l] = r[4 * i.b + l];
        break;
      case Op::sincos4: {
        // One angle's four lanes per call, as the 4-lane sincos_batch calls it; every angle
        // read before a result is written (a result may take an angle's register).
        const std::int32_t* o = operands + i.a;
        double angle[4][4], s[4][4], c[4][4];
        for (int j = 0; j < i.b; ++j) std::memcpy(angle[j], r + 4 * o[j], sizeof angle[j]);
        for (int j = 0; j < i.b; ++j) sin_cos(trig, angle[j], s[j], c[j]);
        for (int j = 0; j < i.b; ++j) {
          std::memcpy(r + 4 * o[4 + j], s[j], sizeof s[j]);
          std::memcpy(r + 4 * o[8 + j], c[j], sizeof c[j]);
        }
        break;
      }
    }
  }
}

}  // namespace spacearm
