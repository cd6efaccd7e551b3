# objscan_lcmtypes(TARGET <name> FILES <a.lcm> ...)
# Runs lcm-gen --cpp on each listed .lcm file into ${CMAKE_BINARY_DIR}/lcmtypes and makes an INTERFACE
# target <name> whose include directory holds the generated headers (#include "objscan/image_t.hpp").
# When a JDK and lcm.jar are found, also compiles the Java classes into <name>.jar (for lcm-spy).
# Generated code lives only in the build tree.
find_program(LCM_GEN_EXECUTABLE lcm-gen REQUIRED)
find_package(Java COMPONENTS Development QUIET)
find_file(LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java NO_DEFAULT_PATH)

function(objscan_lcmtypes)
  cmake_parse_arguments(ARG "" "TARGET;PACKAGE" "FILES" ${ARGN})
  set(out_dir ${CMAKE_BINARY_DIR}/lcmtypes)
  set(cpp_headers)
  set(java_sources)
  foreach(lcm_file ${ARG_FILES})
    get_filename_component(abs ${lcm_file} ABSOLUTE)
    get_filename_component(stem ${lcm_file} NAME_WE)
    set(hpp ${out_dir}/cpp/${ARG_PACKAGE}/${stem}.hpp)
    add_custom_command(
      OUTPUT ${hpp}
      COMMAND ${LCM_GEN_EXECUTABLE} --cpp --cpp-hpath ${out_dir}/cpp ${abs}
      DEPENDS ${abs}
      COMMENT "lcm-gen --cpp ${stem}.lcm"
      VERBATIM)
    list(APPEND cpp_headers ${hpp})
    if(Java_JAVAC_EXECUTABLE AND LCM_JAR)
      set(java ${out_dir}/java/${ARG_PACKAGE}/${stem}.java)
      add_custom_command(
        OUTPUT ${java}
        COMMAND ${LCM_GEN_EXECUTABLE} -j --jpath ${out_dir}/java ${abs}
        DEPENDS ${abs}
        COMMENT "lcm-gen -j ${stem}.lcm"
        VERBATIM)
      list(APPEND java_sources ${java})
    endif()
  endforeach()
  add_custom_target(${ARG_TARGET}_gen DEPENDS ${cpp_headers})
  add_library(${ARG_TARGET} INTERFACE)
  add_dependencies(${ARG_TARGET} ${ARG_TARGET}_gen)
  target_include_directories(${ARG_TARGET} INTERFACE ${out_dir}/cpp)
  if(java_sources)
    set(classes ${out_dir}/java_classes)
    set(jar ${CMAKE_BINARY_DIR}/${ARG_TARGET}.jar)
    add_custom_command(
      OUTPUT ${jar}
      COMMAND ${CMAKE_COMMAND} -E rm -rf ${classes}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${classes}
      COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -cp ${LCM_JAR} -d ${classes} ${java_sources}
      COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${classes} .
      DEPENDS ${java_sources}
      COMMENT "javac + jar ${ARG_TARGET}.jar"
      VERBATIM)
    add_custom_target(${ARG_TARGET}_jar ALL DEPENDS ${jar})
    set(OBJSCAN_LCMTYPES_JAR ${jar} CACHE INTERNAL "jar of the objscan LCM types")
  else()
    message(STATUS "objscan: no JDK or lcm.jar found; ${ARG_TARGET}.jar (for lcm-spy) is not built")
  endif()
endfunction()
