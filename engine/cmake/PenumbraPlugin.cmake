# penumbra_add_plugin(<name> SOURCES <file>... [SHADERS <file>...] [SHADER_DIR <dir>])
#
# Builds the shadow-technique plugin <name> (the name configs use: "technique": "<name>")
# as a loadable module penumbra-<name>.so (target penumbra_plugin_<name>) linked against
# Penumbra::engine, and installs it. The same call works in Penumbra's own tree
# (plugins/CMakeLists.txt includes this file) and in a project of its own after
# find_package(Penumbra), which includes it. See docs/plugins.md.
#
#   SOURCES     the plugin's C++ sources; one of them defines penumbra_plugin_entry.
#   SHADER_DIR  the folder holding the plugin's GLSL (default: the calling CMakeLists.txt's
#               folder). Compiled in as PENUMBRA_PLUGIN_SHADER_DIR (an absolute path) for
#               PenumbraPluginInfo::shaderDir, so that shaders can be edited without
#               rebuilding.
#   SHADERS     the shader files to install, relative to SHADER_DIR (sub-folders are
#               kept). Default: every *.vert *.frag *.comp *.geom *.tesc *.tese *.glsl
#               directly in SHADER_DIR.
#
# Where the module goes:
#   build:    ${PENUMBRA_PLUGIN_OUTPUT_DIR}, by default ${CMAKE_BINARY_DIR}/plugins. In
#             Penumbra's tree the engine searches there itself; out of tree, point
#             PENUMBRA_PLUGIN_PATH at that folder.
#   install:  <prefix>/${CMAKE_INSTALL_LIBDIR}/penumbra/plugins/penumbra-<name>.so, its
#             shaders in .../plugins/<name>/ (where the engine looks when the build-time
#             SHADER_DIR is gone). Installed into the engine's own prefix, a plugin is found
#             without PENUMBRA_PLUGIN_PATH.
include_guard(GLOBAL)
include(GNUInstallDirs)

function(penumbra_add_plugin name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "SHADER_DIR" "SOURCES;SHADERS")
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "penumbra_add_plugin(${name}): unknown arguments: ${arg_UNPARSED_ARGUMENTS}")
  endif()
  # The name is a config value and part of a file name: keep it to what both allow.
  if(NOT name MATCHES "^[a-z0-9][a-z0-9_-]*$")
    message(FATAL_ERROR "penumbra_add_plugin(${name}): a plugin name is lower-case letters, digits, '_' and '-'")
  endif()
  if(NOT arg_SOURCES)
    message(FATAL_ERROR "penumbra_add_plugin(${name}): SOURCES is required")
  endif()
  if(NOT TARGET Penumbra::engine)
    message(FATAL_ERROR "penumbra_add_plugin(${name}): no target Penumbra::engine; call find_package(Penumbra) first")
  endif()

  set(shader_dir "${CMAKE_CURRENT_SOURCE_DIR}")
  if(arg_SHADER_DIR)
    get_filename_component(shader_dir "${arg_SHADER_DIR}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  endif()
  set(shaders ${arg_SHADERS})
  if(NOT shaders)
    file(GLOB shaders CONFIGURE_DEPENDS RELATIVE "${shader_dir}"
         "${shader_dir}/*.vert" "${shader_dir}/*.frag" "${shader_dir}/*.comp" "${shader_dir}/*.geom"
         "${shader_dir}/*.tesc" "${shader_dir}/*.tese" "${shader_dir}/*.glsl")
  endif()
  set(shader_paths "")
  foreach(shader IN LISTS shaders)
    if(NOT EXISTS "${shader_dir}/${shader}")
      message(FATAL_ERROR "penumbra_add_plugin(${name}): shader ${shader} not found in ${shader_dir}")
    endif()
    list(APPEND shader_paths "${shader_dir}/${shader}")
  endforeach()

  set(output_dir "${CMAKE_BINARY_DIR}/plugins")
  if(PENUMBRA_PLUGIN_OUTPUT_DIR)
    set(output_dir "${PENUMBRA_PLUGIN_OUTPUT_DIR}")
  endif()

  set(target penumbra_plugin_${name})
  # The shaders are listed as sources only so that IDEs show them: they are compiled at
  # run time (gpu/ShaderCompiler.h).
  add_library(${target} MODULE ${arg_SOURCES} ${shader_paths})
  target_link_libraries(${target} PRIVATE Penumbra::engine)
  target_compile_features(${target} PRIVATE cxx_std_20)
  target_compile_definitions(${target} PRIVATE PENUMBRA_PLUGIN_SHADER_DIR="${shader_dir}")
  # A symbol the plugin uses but nothing defines is a link error here, not a
  # dependency-missing error when the engine loads the plugin.
  target_link_options(${target} PRIVATE "LINKER:--no-undefined")
  # Every symbol is hidden except what PENUMBRA_PLUGIN_EXPORT marks (the entry point):
  # two plugins that both define a helper `blur()` must never bind to each other's copy.
  # The generator expression in the output folder keeps multi-config generators from
  # appending a per-configuration subfolder: every configuration lands in one folder.
  set_target_properties(${target} PROPERTIES
    PREFIX ""
    OUTPUT_NAME "penumbra-${name}"
    LIBRARY_OUTPUT_DIRECTORY "${output_dir}$<0:>"
    CXX_EXTENSIONS OFF
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON
    # The engine is already loaded when a plugin is; the run path only serves tools such
    # as ldd: installed plugins live in <libdir>/penumbra/plugins, two levels below it.
    INSTALL_RPATH "$ORIGIN/../.."
    INSTALL_RPATH_USE_LINK_PATH ON)

  set(plugin_dir "${CMAKE_INSTALL_LIBDIR}/penumbra/plugins")
  install(TARGETS ${target} LIBRARY DESTINATION "${plugin_dir}")
  foreach(shader IN LISTS shaders)
    get_filename_component(sub "${shader}" DIRECTORY)
    install(FILES "${shader_dir}/${shader}" DESTINATION "${plugin_dir}/${name}/${sub}")
  endforeach()
endfunction()
