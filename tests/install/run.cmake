# Installs the build tree into a scratch prefix, then configures, builds and runs a separate
# project that finds it with find_package(momentum) and calls the library.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "cmake --install failed: ${rc}")
endif()
foreach(required bin/mo-cat share/man/man1/mo-cat.1 share/man/man5/mo-log.5
                 include/momentum/stream/reader.hpp lib/cmake/momentum/momentumConfig.cmake
                 share/bash-completion/completions/mo-cat share/zsh/site-functions/_mo-cat
                 share/momentum/examples/library/CMakeLists.txt)
  if(NOT EXISTS ${WORK_DIR}/prefix/${required})
    message(FATAL_ERROR "not installed: ${required}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the consumer failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the consumer failed")
endif()
execute_process(COMMAND ${WORK_DIR}/build/consumer RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(rc OR NOT out MATCHES "rows=2 sum=7.5")
  message(FATAL_ERROR "consumer failed (${rc}): ${out}")
endif()
message(STATUS "consumer: ${out}")

# The package names no library file of the build machine (urdfdom through its own package).
file(GLOB exported ${WORK_DIR}/prefix/lib*/cmake/momentum/*.cmake ${WORK_DIR}/prefix/lib*/*/cmake/momentum/*.cmake)
foreach(f IN LISTS exported)
  file(READ ${f} text)
  if(text MATCHES "liburdfdom[^ ;\"]*\\.so")
    message(FATAL_ERROR "${f} names a urdfdom library file: ${CMAKE_MATCH_0}")
  endif()
endforeach()

# The installed library example, with the runtime component only: configured with the fitting
# stack and CLI11 made unfindable, it must still configure, build and run.
set(example ${WORK_DIR}/prefix/share/momentum/examples/library)
set(arm ${WORK_DIR}/prefix/share/momentum/robots/paper-arm/paper-arm.json)
execute_process(COMMAND ${CMAKE_COMMAND} -S ${example} -B ${WORK_DIR}/example
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                        -DCMAKE_DISABLE_FIND_PACKAGE_Ceres=TRUE -DCMAKE_DISABLE_FIND_PACKAGE_NLopt=TRUE
                        -DCMAKE_DISABLE_FIND_PACKAGE_CLI11=TRUE
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the installed example with COMPONENTS runtime failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/example RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the installed example failed")
endif()
# First-order observer, K1 = 50 1/s, a disturbance of -5 Nm on joint 2 from t = 0 (the motors
# hold g - 5): r2 = -5 (1 - exp(-50 t)), -3.1606 Nm at 20 ms, -5.0000 at 0.5 s; joint 1 (a
# vertical axis) feels nothing.
set(expected "t=0.020 s r1=0.0000 r2=-3.1606 Nm\nt=0.500 s r1=0.0000 r2=-5.0000 Nm\n")
execute_process(COMMAND ${WORK_DIR}/example/push-at-rest ${arm} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(rc OR NOT out STREQUAL expected)
  message(FATAL_ERROR "installed example (CMake) failed (${rc}): ${out}")
endif()

# The same program through pkg-config.
find_program(PKG_CONFIG pkg-config REQUIRED)
set(ENV{PKG_CONFIG_PATH} "${WORK_DIR}/prefix/lib/pkgconfig:${WORK_DIR}/prefix/lib/x86_64-linux-gnu/pkgconfig")
foreach(pc momentum-runtime momentum)
  execute_process(COMMAND ${PKG_CONFIG} --cflags --libs ${pc} RESULT_VARIABLE rc OUTPUT_VARIABLE flags
                  ERROR_VARIABLE why OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc)
    message(FATAL_ERROR "pkg-config ${pc} failed: ${why}")
  endif()
endforeach()
execute_process(COMMAND ${PKG_CONFIG} --cflags --libs momentum-runtime OUTPUT_VARIABLE flags
                OUTPUT_STRIP_TRAILING_WHITESPACE)
separate_arguments(flags UNIX_COMMAND "${flags}")
execute_process(COMMAND c++ -std=c++20 ${example}/push_at_rest.cpp ${flags} -o ${WORK_DIR}/push-at-rest-pc
                RESULT_VARIABLE rc ERROR_VARIABLE why)
if(rc)
  message(FATAL_ERROR "building the example with pkg-config momentum-runtime failed: ${why}")
endif()
execute_process(COMMAND ${WORK_DIR}/push-at-rest-pc ${arm} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(rc OR NOT out STREQUAL expected)
  message(FATAL_ERROR "installed example (pkg-config) failed (${rc}): ${out}")
endif()
message(STATUS "library example: ${out}")
