#include "cpp_emitter.hpp"

#include "planar_model.hpp"

namespace spacearm {

EmittedModel emit_cpp(const SymbolicModel& model, const EmitOptions& options) {
  LowerOptions lo;
  lo.plain = options.plain;
  PrintOptions po;
  po.scene_path = options.scene_path;
  po.command = options.command;
  po.file_stem = options.file_stem;
  return print_cpp(lower(model, lo), po);
}

}  // namespace spacearm
