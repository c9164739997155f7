# cmake -DBUILD_DIR=... -DCONSUMER_DIR=... -DWORK_DIR=... -DDATASETS_DIR=... -DCXX=...
#       [-DPYTHON=... -DPYTHON_DIR=...] -P this
# Fails (message FATAL_ERROR) naming the step that went wrong.

function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (${rc}):\n${out}\n${err}")
  endif()
  set(LAST_OUTPUT "${out}" PARENT_SCOPE)
endfunction()

function(expect_three_frames how)
  if(NOT LAST_OUTPUT MATCHES "frames in map: 3")
    message(FATAL_ERROR "${how}: the consumer did not map three frames:\n${LAST_OUTPUT}")
  endif()
  message(STATUS "${how}: ${LAST_OUTPUT}")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})

foreach(required bin/placedb include/placedb/map.h include/placedb/error.h
                 share/doc/placedb/LICENSE)
  if(NOT EXISTS ${prefix}/${required})
    message(FATAL_ERROR "cmake --install did not install ${required}")
  endif()
endforeach()
run("installed placedb --version" ${prefix}/bin/placedb --version)
if(NOT LAST_OUTPUT MATCHES "BSD-3-Clause")
  message(FATAL_ERROR "placedb --version names no license: ${LAST_OUTPUT}")
endif()

# Three frames of the RTAB-Map samples where they are present; drawn images otherwise.
set(images "")
set(samples ${DATASETS_DIR}/rtabmap_samples)
if(EXISTS ${samples}/frames.txt)
  file(STRINGS ${samples}/frames.txt lines LIMIT_COUNT 3)
  foreach(line ${lines})
    list(APPEND images ${samples}/${line})
  endforeach()
else()
  message(STATUS "no ${samples}/frames.txt: the consumer maps drawn images")
endif()

run("configure consumer" ${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${WORK_DIR}/consumer
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX})
run("build consumer" ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
run("consumer (CMake package)" ${WORK_DIR}/consumer/consumer ${WORK_DIR}/cmake.placedb ${images})
expect_three_frames("CMake package")

find_program(PKG_CONFIG pkg-config REQUIRED)
file(GLOB pc_file ${prefix}/lib*/pkgconfig/placedb.pc ${prefix}/lib/*/pkgconfig/placedb.pc)
if(NOT pc_file)
  message(FATAL_ERROR "cmake --install did not install placedb.pc")
endif()
get_filename_component(pc_dir ${pc_file} DIRECTORY)
set(ENV{PKG_CONFIG_PATH} ${pc_dir})
run("pkg-config license" ${PKG_CONFIG} --variable=license placedb)
if(NOT LAST_OUTPUT MATCHES "^BSD-3-Clause")
  message(FATAL_ERROR "placedb.pc names no license: ${LAST_OUTPUT}")
endif()
run("pkg-config" ${PKG_CONFIG} --cflags --libs placedb)
string(STRIP "${LAST_OUTPUT}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run("compile consumer with pkg-config" ${CXX} -std=c++17 -O1 ${CONSUMER_DIR}/consumer.cpp
    ${flags} -o ${WORK_DIR}/consumer_pc)
run("consumer (pkg-config)" ${WORK_DIR}/consumer_pc ${WORK_DIR}/pc.placedb ${images})
expect_three_frames("pkg-config")

if(PYTHON AND PYTHON_DIR)
  run("import the installed Python module" ${CMAKE_COMMAND} -E env
      PYTHONPATH=${prefix}/${PYTHON_DIR} ${PYTHON} -c "import placedb\nprint(placedb.__file__)")
  string(FIND "${LAST_OUTPUT}" "${prefix}/" at)
  if(NOT at EQUAL 0)
    message(FATAL_ERROR "the Python module was not imported from the prefix: ${LAST_OUTPUT}")
  endif()
endif()
