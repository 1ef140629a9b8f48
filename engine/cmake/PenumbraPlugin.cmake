# penumbra_add_plugin(<name> SOURCES <file>...)
#
# Builds a technique plugin: a MODULE library penumbra-<name>.so (no "lib" prefix: the
# registry looks for exactly that name) in ${CMAKE_BINARY_DIR}/plugins/, the folder the
# build tree's plugin search path names. It needs only the engine target, so that it
# works in this tree (penumbra_engine) and in an out-of-tree plugin project after
# find_package(Penumbra) (Penumbra::engine).
#
# Every symbol is hidden except what PENUMBRA_PLUGIN_EXPORT marks (the entry point): two
# plugins that both define a helper `blur()` must never bind to each other's copy.
# PENUMBRA_PLUGIN_SHADER_DIR is the calling folder: the plugin's GLSL lives next to its
# C++ (STYLE.md), and the engine's compiler searches there first.
function(penumbra_add_plugin name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "SOURCES")
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "penumbra_add_plugin(${name}): unexpected arguments: ${arg_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT arg_SOURCES)
    message(FATAL_ERROR "penumbra_add_plugin(${name}): SOURCES is empty")
  endif()
  if(TARGET Penumbra::engine)
    set(engine Penumbra::engine)
  elseif(TARGET penumbra_engine)
    set(engine penumbra_engine)
  else()
    message(FATAL_ERROR "penumbra_add_plugin(${name}): no engine target; call find_package(Penumbra) first")
  endif()

  set(target penumbra_plugin_${name})
  add_library(${target} MODULE ${arg_SOURCES})
  target_link_libraries(${target} PRIVATE ${engine})
  target_compile_features(${target} PRIVATE cxx_std_20)
  target_compile_definitions(${target} PRIVATE PENUMBRA_PLUGIN_SHADER_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  # The generator expression in the output folder keeps multi-config generators from
  # appending a per-configuration subfolder: every configuration lands in plugins/.
  set_target_properties(${target} PROPERTIES
    OUTPUT_NAME penumbra-${name}
    PREFIX ""
    LIBRARY_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/plugins$<0:>"
    CXX_EXTENSIONS OFF
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
endfunction()
