# The real image sets the tests read (../shared/data: Middlebury rings, Oxford dinosaur; see each set's SOURCE.txt):
# OBJSCAN_DATA_DIR, else <source>/../shared/data (the checkout's sibling shared/) when it exists. Tests get it in
# their environment (OBJSCAN_DATA_DIR); without it the real-data tests skip and say so.
set(OBJSCAN_DATA_DIR "" CACHE PATH "folder of the real image sets (default: <source>/../shared/data)")
if(NOT OBJSCAN_DATA_DIR)
  foreach(candidate "${PROJECT_SOURCE_DIR}/../shared/data")
    if(IS_DIRECTORY "${candidate}")
      get_filename_component(OBJSCAN_DATA_DIR_FOUND "${candidate}" REALPATH)
      break()
    endif()
  endforeach()
else()
  set(OBJSCAN_DATA_DIR_FOUND "${OBJSCAN_DATA_DIR}")
endif()
if(OBJSCAN_DATA_DIR_FOUND)
  message(STATUS "real image sets for the tests: ${OBJSCAN_DATA_DIR_FOUND}")
else()
  message(WARNING "no real image sets (../shared/data next to the checkout; or set OBJSCAN_DATA_DIR): "
                  "the Middlebury and Oxford dinosaur tests will skip")
endif()

# objscan_test(<name> SOURCES <files...> [LIBS <targets...>] [LABELS <labels...>] [TIMEOUT <s>])
# One line per test: builds <name> against GoogleTest and registers it with CTest (label "unit" by default).
function(objscan_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT BUILD_TESTING)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  add_test(NAME ${name} COMMAND ${name} --gtest_color=no)
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    ENVIRONMENT
    "OBJSCAN_SOURCE_DIR=${PROJECT_SOURCE_DIR};OBJSCAN_BINARY_DIR=${PROJECT_BINARY_DIR};OBJSCAN_DATA_DIR=${OBJSCAN_DATA_DIR_FOUND}")
endfunction()

# objscan_benchmark(<name> SOURCES <files...> [LIBS <targets...>]): a Google Benchmark executable (not a test).
function(objscan_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT TARGET benchmark::benchmark)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} benchmark::benchmark)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
endfunction()
