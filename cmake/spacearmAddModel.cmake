# spacearm_add_model(<target> SCENE <scene.yaml> [PLAIN])
#
# Creates a static library <target> from the code spacearm generates for the scene. The
# sources are regenerated at build time whenever the scene file or the generator changes,
# and only then. Include "<target>.hpp"; the namespace is spacearm::models::<scene name>.
# PLAIN generates the expanded, CSE-free baseline (generate --plain), for benchmarks.
# The one build rule for generated models: used by tests/, bench/ and outside projects.
#
# SPACEARM_VECTOR_TRIG (default ON on x86-64 where glibc's libmvec is found): the generated
# sources compute each function's sin and cos four at a time through libmvec on CPUs with AVX2
# and FMA (within 4 ulp instead of libm's 1); OFF keeps std::sin and std::cos.
find_library(SPACEARM_LIBMVEC mvec)
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND CMAKE_SIZEOF_VOID_P EQUAL 8
   AND SPACEARM_LIBMVEC)
  option(SPACEARM_VECTOR_TRIG "generated models: sin and cos through glibc's libmvec" ON)
else()
  option(SPACEARM_VECTOR_TRIG "generated models: sin and cos through glibc's libmvec" OFF)
endif()

# What every library of generated sources is built with (also the checked-in generated/).
function(spacearm_model_build_options target)
  if(SPACEARM_VECTOR_TRIG)
    if(NOT SPACEARM_LIBMVEC)
      message(FATAL_ERROR "SPACEARM_VECTOR_TRIG is ON but glibc's libmvec was not found")
    endif()
    target_compile_definitions(${target} PRIVATE SPACEARM_VECTOR_TRIG)
    # By name: glibc's libm (linker script) pulls in libmvec where it is used, shared or static.
    target_link_libraries(${target} PUBLIC m)
  endif()
endfunction()

function(spacearm_add_model target)
  cmake_parse_arguments(ARG "PLAIN" "SCENE" "" ${ARGN})
  if(NOT ARG_SCENE)
    message(FATAL_ERROR "spacearm_add_model(${target}): SCENE <file> is required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "spacearm_add_model(${target}): unknown arguments '${ARG_UNPARSED_ARGUMENTS}'")
  endif()
  get_filename_component(scene "${ARG_SCENE}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  if(NOT EXISTS "${scene}")
    message(FATAL_ERROR "spacearm_add_model(${target}): scene '${scene}' does not exist")
  endif()
  set(flags)
  if(ARG_PLAIN)
    set(flags --plain)
  endif()
  # A spatial scene's URDF (`urdf: FILE`, beside the scene) is an input too: an edited URDF
  # regenerates the model; an edited scene re-reads which URDF it names.
  set(inputs "${scene}")
  file(STRINGS "${scene}" urdf_line REGEX "^urdf:[ \t]*[^ \t#]+" LIMIT_COUNT 1)
  if(urdf_line)
    string(REGEX REPLACE "^urdf:[ \t]*[\"']?([^\"' \t#]+).*$" "\\1" urdf "${urdf_line}")
    get_filename_component(scene_dir "${scene}" DIRECTORY)
    get_filename_component(urdf "${urdf}" ABSOLUTE BASE_DIR "${scene_dir}")
    list(APPEND inputs "${urdf}")
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${scene}")
  endif()
  set(dir "${CMAKE_CURRENT_BINARY_DIR}/spacearm_models/${target}")
  add_custom_command(
    OUTPUT "${dir}/${target}.hpp" "${dir}/${target}.cpp"
    COMMAND spacearm::spacearm generate "${scene}" -o "${dir}" --file-stem "${target}" ${flags}
    DEPENDS ${inputs} "$<TARGET_FILE:spacearm::spacearm>"
    COMMENT "spacearm: generating model ${target} from ${ARG_SCENE}"
    VERBATIM)
  add_library(${target} STATIC "${dir}/${target}.cpp" "${dir}/${target}.hpp")
  target_include_directories(${target} PUBLIC "$<BUILD_INTERFACE:${dir}>")
  target_link_libraries(${target} PUBLIC Eigen3::Eigen)
  spacearm_model_build_options(${target})
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()
