# skidimm_add_motion_model(<target> <sources...> [INSTALL [DESTINATION <dir>]])
#
# Builds a motion-model plugin: a MODULE library (never linked into anything,
# only loaded at run time) with hidden visibility, so it exports nothing but
# the symbols SKIDIMM_EXPORT_MOTION_MODEL declares. The file is named
# <target>.so, without the "lib" prefix, which is the name `skidimm plugins`
# shows next to the model.
#
# INSTALL installs it with `cmake --install` into DESTINATION (relative to the
# install prefix; default lib/skidimm/plugins), atomically: the file is copied
# under a temporary name in the destination directory and renamed over the
# old one. A skidimm that is running with the old file keeps its (private)
# copy, and one starting meanwhile sees the old file or the new one, never half
# of one. Replace plugin files by hand the same way: `mv` or `install`, never
# `cp` over a plugin in place.
function(skidimm_add_motion_model target)
  cmake_parse_arguments(PARSE_ARGV 1 SKIDIMM_PLUGIN "INSTALL" "DESTINATION" "")
  set(sources ${SKIDIMM_PLUGIN_UNPARSED_ARGUMENTS})
  if(NOT sources)
    message(FATAL_ERROR "skidimm_add_motion_model(${target}) needs at least one source file")
  endif()
  if(DEFINED SKIDIMM_PLUGIN_DESTINATION AND NOT SKIDIMM_PLUGIN_INSTALL)
    message(FATAL_ERROR "skidimm_add_motion_model(${target}): DESTINATION is given without INSTALL")
  endif()
  add_library(${target} MODULE ${sources})
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
  if(SKIDIMM_PLUGIN_INSTALL)
    if(NOT DEFINED SKIDIMM_PLUGIN_DESTINATION)
      set(SKIDIMM_PLUGIN_DESTINATION lib/skidimm/plugins)
    endif()
    # install(TARGETS) may write the destination in place; this never does.
    install(CODE "
      set(_dir \"${SKIDIMM_PLUGIN_DESTINATION}\")
      if(NOT IS_ABSOLUTE \"\${_dir}\")
        set(_dir \"\${CMAKE_INSTALL_PREFIX}/\${_dir}\")
      endif()
      set(_dir \"\$ENV{DESTDIR}\${_dir}\")
      set(_file \"\${_dir}/$<TARGET_FILE_NAME:${target}>\")
      set(_temporary \"\${_dir}/.$<TARGET_FILE_NAME:${target}>.installing\")
      message(STATUS \"Installing (by rename): \${_file}\")
      file(MAKE_DIRECTORY \"\${_dir}\")
      execute_process(COMMAND \"\${CMAKE_COMMAND}\" -E copy \"$<TARGET_FILE:${target}>\" \"\${_temporary}\"
                      RESULT_VARIABLE _copied)
      if(NOT _copied EQUAL 0)
        message(FATAL_ERROR \"cannot copy $<TARGET_FILE:${target}> to \${_temporary}\")
      endif()
      file(RENAME \"\${_temporary}\" \"\${_file}\")
      list(APPEND CMAKE_INSTALL_MANIFEST_FILES \"\${_file}\")
    ")
  endif()
endfunction()
