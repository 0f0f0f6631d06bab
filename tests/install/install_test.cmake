# `cmake --install` into a fresh prefix, then a downstream project (consumer/) configured with
# find_package(imukit), built against the installed tree only and run; also checks the installed
# layout (headers as <module>/<header>.hpp, the command, the udev rule, the demo's motion).
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DGENERATOR=... -DCXX=... -P install_test.cmake
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR GENERATOR CXX)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "install_test.cmake: -D${var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)

execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix}
                OUTPUT_QUIET COMMAND_ERROR_IS_FATAL ANY)
foreach(f include/imukit/core/imu_series.hpp include/imukit/sim/scene.hpp
          include/imukit/firmware_proto/messages.hpp lib/cmake/imukit/imukitConfig.cmake
          lib/cmake/imukit/imukitConfigVersion.cmake lib/cmake/imukit/imukitTargets.cmake
          bin/imukit lib/udev/rules.d/70-imukit.rules share/imukit/motion/cmu_131_01_walk_2s.bvh)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
message(STATUS "installed layout: ok")

execute_process(COMMAND ${prefix}/bin/imukit --version OUTPUT_VARIABLE version COMMAND_ERROR_IS_FATAL ANY)
if(NOT version MATCHES "^imukit [0-9]+\\.[0-9]+\\.[0-9]+")
  message(FATAL_ERROR "installed imukit --version printed '${version}'")
endif()

# The consumer sees only the installed tree: no path into the source or build folder.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer -B ${WORK_DIR}/consumer
                        -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_PREFIX_PATH=${prefix}
                        "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}"
                        -DCMAKE_BUILD_TYPE=Release
                OUTPUT_QUIET COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${WORK_DIR}/consumer/consumer ${prefix}/share/imukit/motion/cmu_131_01_walk_2s.bvh
                COMMAND_ERROR_IS_FATAL ANY)
file(REMOVE_RECURSE ${WORK_DIR})
