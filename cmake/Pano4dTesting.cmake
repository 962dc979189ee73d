# pano4d_add_test(NAME <target> SOURCES <files...> LIBS <targets...>
#                 [LABELS unit|real-data|slow ...] [TIMEOUT seconds])
# One GoogleTest executable per source file with logic; every test case is
# registered with ctest individually and carries the given labels. TIMEOUT
# overrides ctest's --timeout (scripts/test.sh: 900 s) for tests known to be
# long, such as whole pipelines on real captures.
include(GoogleTest)
find_package(GTest REQUIRED)

function(pano4d_add_test)
  cmake_parse_arguments(ARG "" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${ARG_NAME} PRIVATE
    PANO4D_DATA_DIR="${PANO4D_DATA_DIR}"
    PANO4D_BINARY_DIR="${CMAKE_BINARY_DIR}"
    PANO4D_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set(properties LABELS "${ARG_LABELS}")
  if(ARG_TIMEOUT)
    list(APPEND properties TIMEOUT ${ARG_TIMEOUT})
  endif()
  # PRE_TEST discovery keeps the build from running every test binary.
  gtest_discover_tests(${ARG_NAME}
    DISCOVERY_MODE PRE_TEST
    PROPERTIES ${properties})
endfunction()
