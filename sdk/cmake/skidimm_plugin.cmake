# skidimm_add_motion_model(<target> <sources...>)
#
# Builds a motion-model plugin: a MODULE library (never linked into anything,
# only loaded at run time) with hidden visibility, so it exports nothing but
# the symbols SKIDIMM_EXPORT_MOTION_MODEL declares. The file is named
# <target>.so, without the "lib" prefix, which is the name `skidimm plugins`
# shows next to the model.
function(skidimm_add_motion_model target)
  if(ARGC LESS 2)
    message(FATAL_ERROR "skidimm_add_motion_model(${target}) needs at least one source file")
  endif()
  add_library(${target} MODULE ${ARGN})
  target_link_libraries(${target} PRIVATE skidimm::sdk)
  set_target_properties(${target} PROPERTIES
    PREFIX ""
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  if(DEFINED SKIDIMM_PLUGIN_OUTPUT_DIRECTORY)
    set_target_properties(${target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${SKIDIMM_PLUGIN_OUTPUT_DIRECTORY})
  endif()
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU")
    # Without this, GNU unique symbols pin the library in memory forever and
    # hide use-after-unload bugs (see docs/writing-a-model-plugin.md).
    target_compile_options(${target} PRIVATE -fno-gnu-unique)
  endif()
endfunction()
