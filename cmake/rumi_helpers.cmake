# Shared build conventions: one library per folder, foo.cc / foo_test.cc side by side.
set(RUMI_WARNINGS -Wall -Wextra -Wpedantic -Wno-unused-parameter)

# rumi_use_popcnt(TARGET): Hamming distances of ORB descriptors
# (DescriptorDistance in common/orb_extractor.h, inline) dominate matching;
# on x86-64 compile TARGET with the POPCNT instruction (without it the
# popcount is a bit-twiddling sequence, 2x slower than cv::BFMatcher).
function(rumi_use_popcnt target)
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64")
    target_compile_options(${target} PRIVATE -mpopcnt)
  endif()
endfunction()

# rumi_folder_library(NAME DEPS... [TEST_DEPS...] [EXCLUDE file.cc...])
# Builds every *.cc of the current folder that is not a test, benchmark, *_main.cc
# or excluded into library NAME, and registers each *_test.cc as a ctest test
# linked against it and the test support (common/testing).
function(rumi_folder_library name)
  cmake_parse_arguments(ARG "" "" "DEPS;TEST_DEPS;EXCLUDE" ${ARGN})
  file(GLOB _all CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cc)
  foreach(x ${ARG_EXCLUDE})
    list(REMOVE_ITEM _all ${CMAKE_CURRENT_SOURCE_DIR}/${x})
  endforeach()
  set(_lib)
  set(_tests)
  set(_benches)
  foreach(f ${_all})
    get_filename_component(_n ${f} NAME_WE)
    if(_n MATCHES "_test$")
      list(APPEND _tests ${f})
    elseif(_n MATCHES "_benchmark$")
      list(APPEND _benches ${f})
    elseif(NOT _n MATCHES "_main$")
      list(APPEND _lib ${f})
    endif()
  endforeach()
  if(_lib)
    add_library(${name} STATIC ${_lib})
    target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
    target_compile_options(${name} PRIVATE ${RUMI_WARNINGS})
    target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  else()  # folder not populated yet
    add_library(${name} INTERFACE)
    target_include_directories(${name} INTERFACE ${PROJECT_SOURCE_DIR})
    target_link_libraries(${name} INTERFACE ${ARG_DEPS})
  endif()
  if(RUMI_BUILD_TESTS)
    foreach(t ${_tests})
      get_filename_component(_n ${t} NAME_WE)
      rumi_add_test(${_n} SOURCES ${t} DEPS ${name} ${ARG_TEST_DEPS} rumi_testing)
    endforeach()
  endif()
  if(RUMI_BUILD_BENCHMARKS)
    foreach(b ${_benches})
      get_filename_component(_n ${b} NAME_WE)
      add_executable(${_n} ${b})
      target_compile_options(${_n} PRIVATE ${RUMI_WARNINGS})
      target_link_libraries(${_n} PRIVATE ${name} benchmark::benchmark)
    endforeach()
  endif()
endfunction()

# rumi_add_test(NAME SOURCES ... DEPS ...)
function(rumi_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  # Test code is compiled, not timed: -O1 takes a third less compile time
  # than the release -O3 (what the tests exercise, the libraries, stays -O3).
  target_compile_options(${name} PRIVATE ${RUMI_WARNINGS} $<$<CONFIG:Release>:-O1>)
  target_compile_definitions(${name} PRIVATE
    RUMI_SHARED_DATA_DIR="${RUMI_SHARED_DATA_DIR}"
    RUMI_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    RUMI_BINARY_DIR="${PROJECT_BINARY_DIR}")
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES TIMEOUT 600
    ENVIRONMENT "RUMI_BIN_DIR=${CMAKE_BINARY_DIR}/bin")
endfunction()

# rumi_add_executable(NAME SOURCES ... DEPS ...)
function(rumi_add_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_compile_options(${name} PRIVATE ${RUMI_WARNINGS})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  install(TARGETS ${name} RUNTIME DESTINATION bin)
endfunction()
