# Build helpers shared by every module: one library target per module, one test binary per
# module, benchmarks and fuzzers, all with the same warnings and sanitizers.

function(imukit_configure_toolchain)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    add_compile_options(-Wall -Wextra -Wpedantic)
    if(IMUKIT_WERROR)
      add_compile_options(-Werror)
    endif()
  endif()
  # Floating point results must not depend on whether the compiler fuses a*b+c (portable RNG,
  # bit-exact round trips); FMA is still used where the code asks for it with std::fma.
  add_compile_options(-ffp-contract=off)
  if(IMUKIT_ASSERTIONS)
    foreach(config RELEASE RELWITHDEBINFO MINSIZEREL)
      string(REPLACE "-DNDEBUG" "" flags "${CMAKE_CXX_FLAGS_${config}}")
      set(CMAKE_CXX_FLAGS_${config} "${flags}" PARENT_SCOPE)
      string(REPLACE "-DNDEBUG" "" cflags "${CMAKE_C_FLAGS_${config}}")
      set(CMAKE_C_FLAGS_${config} "${cflags}" PARENT_SCOPE)
    endforeach()
  endif()
  if(IMUKIT_SANITIZE)
    add_compile_options(-fsanitize=${IMUKIT_SANITIZE} -fno-omit-frame-pointer
                        -fno-sanitize-recover=all)
    add_link_options(-fsanitize=${IMUKIT_SANITIZE})
  endif()
  if(IMUKIT_BUILD_FUZZERS)
    if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
      message(FATAL_ERROR "IMUKIT_BUILD_FUZZERS needs clang (libFuzzer)")
    endif()
    add_compile_options(-fsanitize=fuzzer-no-link)
  endif()
endfunction()

# imukit_add_module(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates imukit_<name> with alias imukit::<name>; headers live beside the sources and are
# included as "<name>/<header>.hpp" from the project root.
function(imukit_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(imukit_${name} ${ARG_SOURCES})
  add_library(imukit::${name} ALIAS imukit_${name})
  target_include_directories(imukit_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}> $<INSTALL_INTERFACE:include/imukit>)
  target_link_libraries(imukit_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(imukit_${name} PROPERTIES EXPORT_NAME ${name})
endfunction()

# imukit_add_test_suite(<module> SOURCES ... [DEPS ...])
# One GoogleTest binary per module; every TEST becomes its own ctest entry.
function(imukit_add_test_suite module)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target imukit_${module}_tests)
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE imukit_test_support ${ARG_DEPS} GTest::gtest GTest::gmock
                                          GTest::gtest_main)
  gtest_discover_tests(${target} DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS ${module})
endfunction()

# imukit_add_benchmark(<name> SOURCES ... [DEPS ...])
function(imukit_add_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(bench_${name} ${ARG_SOURCES})
  target_link_libraries(bench_${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
endfunction()

# imukit_add_fuzzer(<name> SOURCES ... [DEPS ...] [CORPUS dir])
function(imukit_add_fuzzer name)
  cmake_parse_arguments(ARG "" "CORPUS" "SOURCES;DEPS" ${ARGN})
  add_executable(fuzz_${name} ${ARG_SOURCES})
  target_link_libraries(fuzz_${name} PRIVATE ${ARG_DEPS})
  target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  set_property(GLOBAL APPEND PROPERTY IMUKIT_FUZZERS "fuzz_${name}|${ARG_CORPUS}")
endfunction()
