#include "model_recipe.hpp"

#include <chrono>

#include "planar_model.hpp"
#include "spatial_model.hpp"

namespace spacearm {

ModelRecipe::ModelRecipe(Scene scene)
    : planar_(std::make_shared<const Scene>(std::move(scene))), facts_(planar_facts(*planar_)) {}

ModelRecipe::ModelRecipe(SpatialScene scene)
    : spatial_(std::make_shared<const SpatialScene>(std::move(scene))),
      facts_(spatial_facts(*spatial_)) {}

ModelRecipe ModelRecipe::parse(const std::string& text, const std::string& source_path) {
  if (is_spatial_scene(text)) return ModelRecipe(parse_spatial_scene(text, source_path));
  return ModelRecipe(parse_scene(text, source_path));
}

const std::string& ModelRecipe::content() const {
  return planar_ ? planar_->content : spatial_->content;
}

const std::string& ModelRecipe::source_path() const {
  return planar_ ? planar_->source_path : spatial_->source_path;
}

EmittedModel ModelRecipe::emit(const EmitOptions& options, double* derive_ms) const {
  const auto t0 = std::chrono::steady_clock::now();
  auto derived = [&] {
    if (derive_ms)
      *derive_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  // A planar scene through its Lagrangian derivation, a spatial one through the spatial chain
  // (recorded when lowered): both then share lowering and the printer.
  if (planar_) {
    const SymbolicModel model = derive(*planar_);
    derived();
    return emit_cpp(model, options);
  }
  const DerivedModel model = spatial_derived_model(*spatial_);
  derived();
  return emit_cpp(model, options);
}

}  // namespace spacearm
