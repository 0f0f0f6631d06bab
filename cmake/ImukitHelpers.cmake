# Build helpers shared by every module: one library target per module, one test binary per
# module, benchmarks and fuzzers, all with the same warnings and sanitizers; installation as a
# CMake package.

include(GNUInstallDirs)

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
  endif()
endfunction()

# Coverage instrumentation for libFuzzer on the code the fuzzers drive: the modules' libraries and
# the fuzzers themselves (imukit_add_module, imukit_add_fuzzer). The test binaries, the CLI and the
# Python module in the same sanitizer build stay without it: no fuzzer runs their code, so there the
# hooks would only cost compile and run time (a few per cent: docs/benchmarks.md). Eigen's and Ceres' own functions
# are left out too (cmake/coverage_ignorelist.txt): coverage inside them steers no fuzzer.
function(_imukit_instrument_for_fuzzing target)
  if(IMUKIT_BUILD_FUZZERS)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link
      -fsanitize-coverage-ignorelist=${PROJECT_SOURCE_DIR}/cmake/coverage_ignorelist.txt)
  endif()
endfunction()

# imukit_add_module(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...] [INTERNAL_HEADERS ...])
# Creates imukit_<name> with alias imukit::<name>. Headers live beside the sources and everything,
# inside the project and outside, includes them as "imukit/<name>/<header>.hpp": in the build tree
# <build>/include/imukit/<name> is a link to this folder, installed they are copied to
# <prefix>/include/imukit/<name>. INTERNAL_HEADERS are the module's plumbing (used by its sources
# and the project's tests, benchmarks and fuzzers): never installed, and no installed header may
# include one (tests/install proves both).
function(imukit_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS;INTERNAL_HEADERS" ${ARGN})
  add_library(imukit_${name} ${ARG_SOURCES})
  add_library(imukit::${name} ALIAS imukit_${name})
  _imukit_instrument_for_fuzzing(imukit_${name})
  file(MAKE_DIRECTORY ${PROJECT_BINARY_DIR}/include/imukit)
  file(CREATE_LINK ${CMAKE_CURRENT_SOURCE_DIR} ${PROJECT_BINARY_DIR}/include/imukit/${name} SYMBOLIC)
  target_include_directories(imukit_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(imukit_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(imukit_${name} PROPERTIES EXPORT_NAME ${name})
  set_property(GLOBAL APPEND PROPERTY IMUKIT_MODULES ${name})
  file(GLOB headers RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_SOURCE_DIR}/*.hpp ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  foreach(h IN LISTS ARG_INTERNAL_HEADERS)  # a misspelt name must not let the header be installed
    if(NOT h IN_LIST headers)
      message(FATAL_ERROR "imukit_add_module(${name}): INTERNAL_HEADERS names ${h}, which is not here")
    endif()
    set_property(GLOBAL APPEND PROPERTY IMUKIT_INTERNAL_HEADERS imukit/${name}/${h})
  endforeach()
  if(ARG_INTERNAL_HEADERS)
    list(REMOVE_ITEM headers ${ARG_INTERNAL_HEADERS})
  endif()
  foreach(h IN LISTS headers)
    set_property(GLOBAL APPEND PROPERTY IMUKIT_PUBLIC_HEADERS imukit/${name}/${h})
  endforeach()
  list(TRANSFORM headers PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/)
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/imukit/${name} COMPONENT dev)
endfunction()

# The third-party packages behind a module's link dependencies, as the lines imukitConfig.cmake
# needs to find them again (static libraries carry their private dependencies to the consumer).
# A target Pkg::name comes from find_package(Pkg); PkgConfig::X from pkg_check_modules, whose
# module name CMake remembers in X_MODULE_NAME.
function(_imukit_dependency_lines target out_var)
  set(lines "")
  get_target_property(deps ${target} LINK_LIBRARIES)
  get_target_property(iface ${target} INTERFACE_LINK_LIBRARIES)
  foreach(dep IN LISTS deps iface)
    string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
    if(dep MATCHES "^imukit" OR NOT dep MATCHES "::" OR dep MATCHES "^\\$<")
      continue()
    endif()
    string(REGEX MATCH "^[^:]+" package "${dep}")
    if(package STREQUAL "PkgConfig")
      string(REGEX REPLACE "^PkgConfig::" "" prefix "${dep}")
      if(NOT ${prefix}_MODULE_NAME)
        message(FATAL_ERROR "imukit install: cannot tell which pkg-config module made ${dep}")
      endif()
      list(APPEND lines "find_dependency(PkgConfig)"
           "pkg_check_modules(${prefix} REQUIRED QUIET IMPORTED_TARGET ${${prefix}_MODULE_NAME})")
    else()
      list(APPEND lines "find_dependency(${package})")
    endif()
  endforeach()
  set(${out_var} "${lines}" PARENT_SCOPE)
endfunction()

# Installs every module registered by imukit_add_module (libraries, headers) with a CMake package
# (imukitConfig.cmake, version file, exported targets imukit::<module>), so that a downstream
# project can find_package(imukit) and link imukit::sim. Call once, after every module.
function(imukit_install_package)
  include(CMakePackageConfigHelpers)
  get_property(modules GLOBAL PROPERTY IMUKIT_MODULES)
  set(targets "")
  set(dependency_lines "")
  foreach(m IN LISTS modules)
    list(APPEND targets imukit_${m})
    _imukit_dependency_lines(imukit_${m} lines)
    list(APPEND dependency_lines ${lines})
  endforeach()
  list(REMOVE_DUPLICATES dependency_lines)
  list(JOIN dependency_lines "\n" IMUKIT_FIND_DEPENDENCIES)
  set(IMUKIT_MODULES "${modules}")
  install(TARGETS ${targets} EXPORT imukitTargets COMPONENT dev
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  set(cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/imukit)
  install(EXPORT imukitTargets NAMESPACE imukit:: DESTINATION ${cmake_dir} COMPONENT dev)
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/imukitConfig.cmake.in
                                ${PROJECT_BINARY_DIR}/imukitConfig.cmake INSTALL_DESTINATION ${cmake_dir})
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/imukitConfigVersion.cmake
                                   VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/imukitConfig.cmake ${PROJECT_BINARY_DIR}/imukitConfigVersion.cmake
          DESTINATION ${cmake_dir} COMPONENT dev)
  # Which headers are public and which internal, for tests/install (not installed).
  get_property(public GLOBAL PROPERTY IMUKIT_PUBLIC_HEADERS)
  get_property(internal GLOBAL PROPERTY IMUKIT_INTERNAL_HEADERS)
  file(WRITE ${PROJECT_BINARY_DIR}/imukit_headers.cmake
       "set(IMUKIT_PUBLIC_HEADERS \"${public}\")\nset(IMUKIT_INTERNAL_HEADERS \"${internal}\")\n")
endfunction()

# imukit_compile_as_program(<target>)
# The programs (test binaries, the imukit command, the Python module) compile as unity builds:
# their files, in batches of 8, parse GoogleTest, CLI11 (9 s a file on its own), pybind11 and Eigen
# once per batch instead of once per file; with the tests' own files at -O1 (imukit_add_test_suite)
# the release build's compile time fell by about 40 % (docs/benchmarks.md, "Build: programs as
# unity builds"). The libraries stay one file at a time, so a library file that only compiles
# thanks to a neighbour's includes still fails, and tests/install compiles every public header on
# its own. -DIMUKIT_UNITY_PROGRAMS=OFF turns it off (quicker rebuilds after editing one test file).
function(imukit_compile_as_program target)
  if(IMUKIT_UNITY_PROGRAMS)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON)
  endif()
endfunction()

# imukit_add_test_suite(<module> SOURCES ... [DEPS ...])
# One GoogleTest binary per module; every TEST becomes its own ctest entry.
function(imukit_add_test_suite module)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target imukit_${module}_tests)
  add_executable(${target} ${ARG_SOURCES})
  imukit_compile_as_program(${target})
  target_compile_options(${target} PRIVATE $<$<CONFIG:Release,RelWithDebInfo>:-O1>)
  target_link_libraries(${target} PRIVATE imukit_test_support ${ARG_DEPS} GTest::gtest GTest::gmock
                                          GTest::gtest_main)
  # Sanitizer builds run the tests in quick mode (tests/support/test_data.hpp: quick_mode()).
  set(quick "")
  if(IMUKIT_SANITIZE)
    set(quick ENVIRONMENT IMUKIT_TEST_QUICK=1)
  endif()
  gtest_discover_tests(${target} DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS ${module} ${quick})
endfunction()

# imukit_add_pytest(<ctest name> <file> [LABELS ...] [ENVIRONMENT ...] [TIMEOUT s])
# One ctest entry runs every test of one pytest file (tests/pytest.ini, tests/conftest.py) with
# ${IMUKIT_PYTHON}; the command under test is $IMUKIT_CLI, and sanitizer builds set
# IMUKIT_TEST_QUICK=1 (the tests that take minutes shorten themselves). One entry per file, not per
# test: listing the tests at configure time would import the Python module before it is built, and
# per-test entries would repeat a file's shared runs (one `imukit demo` takes minutes). A single
# test runs alone through pytest itself (the command in tests/pytest.ini); `-ra` names every
# failed or skipped test in the ctest log.
function(imukit_add_pytest name file)
  cmake_parse_arguments(ARG "" "TIMEOUT" "LABELS;ENVIRONMENT" ${ARGN})
  add_test(NAME ${name}
           COMMAND ${IMUKIT_PYTHON} -m pytest -v -c ${PROJECT_SOURCE_DIR}/tests/pytest.ini
                   --rootdir ${PROJECT_SOURCE_DIR}/tests ${file})
  set(env "IMUKIT_CLI=$<TARGET_FILE:imukit>" "PYTHONDONTWRITEBYTECODE=1" ${ARG_ENVIRONMENT})
  if(IMUKIT_SANITIZE)
    list(APPEND env "IMUKIT_TEST_QUICK=1")
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}" ENVIRONMENT "${env}")
  if(ARG_TIMEOUT)
    set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  endif()
endfunction()

# imukit_add_benchmark(<name> SOURCES ... [DEPS ...])
function(imukit_add_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(bench_${name} ${ARG_SOURCES})
  # Benchmarks share the tests' header-only helpers (tests/support).
  target_include_directories(bench_${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_link_libraries(bench_${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
endfunction()

# imukit_add_fuzzer(<name> SOURCES ... [DEPS ...] [CORPUS dir])
function(imukit_add_fuzzer name)
  cmake_parse_arguments(ARG "" "CORPUS" "SOURCES;DEPS" ${ARGN})
  add_executable(fuzz_${name} ${ARG_SOURCES})
  target_link_libraries(fuzz_${name} PRIVATE ${ARG_DEPS})
  _imukit_instrument_for_fuzzing(fuzz_${name})
  target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  set_property(GLOBAL APPEND PROPERTY IMUKIT_FUZZERS "fuzz_${name}|${ARG_CORPUS}")
endfunction()
