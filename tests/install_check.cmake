# Installs the build into PREFIX and runs the installed binary from a folder that
# holds no scenes: `config/...` must resolve through the binary's own tree (or the
# source tree it was built from), and the installed files must be there.
file(REMOVE_RECURSE ${PREFIX})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX} RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc})")
endif()
foreach(f bin/graspsim share/graspsim/config/paper_box_grasp.yaml share/graspsim/assets/demo_session.lcmlog)
  if(NOT EXISTS ${PREFIX}/${f})
    message(FATAL_ERROR "not installed: ${PREFIX}/${f}")
  endif()
endforeach()
execute_process(COMMAND ${PREFIX}/bin/graspsim scene check ${PREFIX}/share/graspsim/config/tracked_hand.yaml
                WORKING_DIRECTORY ${PREFIX} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the installed binary refused its own scene (${rc}): ${out}${err}")
endif()
execute_process(COMMAND ${PREFIX}/bin/graspsim run config/tracked_hand.yaml --duration 0.01 --quiet
                WORKING_DIRECTORY ${PREFIX} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the installed binary cannot run config/tracked_hand.yaml from ${PREFIX} (${rc}): ${out}${err}")
endif()
file(REMOVE_RECURSE ${PREFIX})
