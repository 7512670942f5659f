# The installed package, end to end (ctest -L package): installs the already built tree into a
# scratch prefix, configures, builds and runs tests/package/consumer against it alone, and checks
# what the consumer and the installed CLI print. Nothing of formfactor is rebuilt.
#
#   cmake -DFF_BUILD_DIR=build -DFF_WORK_DIR=DIR -DFF_VERSION=X.Y.Z [-DFF_GENERATOR=...]
#         [-DFF_CXX_COMPILER=...] [-DFF_LAUNCHER=ccache] [-DFF_BUILD_TYPE=Release]
#         [-DFF_CXX_FLAGS=...] [-DFF_LINK_FLAGS=...] -P tests/package/run.cmake

cmake_minimum_required(VERSION 3.25)

foreach(var FF_BUILD_DIR FF_WORK_DIR FF_VERSION)
    if(NOT DEFINED ${var})
        message(FATAL_ERROR "run.cmake: -D${var}=... is required")
    endif()
endforeach()

set(prefix ${FF_WORK_DIR}/prefix)
set(consumer_build ${FF_WORK_DIR}/consumer-build)
file(REMOVE_RECURSE ${FF_WORK_DIR})

# Runs a command; on failure prints what it said and stops.
function(step name)
    execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
        message(FATAL_ERROR "${name} failed (${rc}):\n${ARGN}\n${out}\n${err}")
    endif()
    set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("install" ${CMAKE_COMMAND} --install ${FF_BUILD_DIR} --prefix ${prefix})
foreach(file include/formfactor/formfactor.h include/formfactor/scene/scene.h bin/formfactor)
    if(NOT EXISTS ${prefix}/${file})
        message(FATAL_ERROR "not installed: ${prefix}/${file}")
    endif()
endforeach()
step("installed CLI" ${prefix}/bin/formfactor --version)
string(FIND "${step_output}" "formfactor ${FF_VERSION}\n" at)
if(NOT at EQUAL 0)
    message(FATAL_ERROR "installed CLI --version printed '${step_output}'")
endif()

set(args -S ${CMAKE_CURRENT_LIST_DIR}/consumer -B ${consumer_build}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
if(FF_GENERATOR)
    list(APPEND args -G ${FF_GENERATOR})
endif()
foreach(pair CMAKE_CXX_COMPILER:FF_CXX_COMPILER CMAKE_CXX_COMPILER_LAUNCHER:FF_LAUNCHER
        CMAKE_BUILD_TYPE:FF_BUILD_TYPE CMAKE_CXX_FLAGS:FF_CXX_FLAGS
        CMAKE_EXE_LINKER_FLAGS:FF_LINK_FLAGS)
    string(REPLACE ":" ";" pair ${pair})
    list(GET pair 0 cmake_var)
    list(GET pair 1 our_var)
    if(${our_var})
        list(APPEND args "-D${cmake_var}=${${our_var}}")
    endif()
endforeach()
step("consumer configure" ${CMAKE_COMMAND} ${args})

# The package found must be the one just installed, not the build tree or a system copy.
file(STRINGS ${consumer_build}/CMakeCache.txt found_dir REGEX "^formfactor_DIR:")
string(REGEX REPLACE "^[^=]*=" "" found_dir "${found_dir}")
file(REAL_PATH ${prefix} real_prefix)
file(REAL_PATH ${found_dir} real_found_dir)
string(FIND "${real_found_dir}" "${real_prefix}/" at)
if(NOT at EQUAL 0)
    message(FATAL_ERROR "find_package(formfactor) found ${found_dir}, not the package in ${prefix}")
endif()

step("consumer build" ${CMAKE_COMMAND} --build ${consumer_build})
step("consumer run" ${consumer_build}/consumer)
message(STATUS "consumer: ${step_output}")
if(NOT step_output MATCHES "^formfactor ${FF_VERSION}, analytic: 24 patches, max \\|row sum - 1\\| = ")
    message(FATAL_ERROR "unexpected consumer output: ${step_output}")
endif()
