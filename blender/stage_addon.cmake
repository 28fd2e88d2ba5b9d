# cmake -P: copies the add-on's Python files and the `relief` package (compiled module included)
# into STAGE/relief_blender, then zips STAGE/relief_blender into ZIP (paths in the zip start with
# relief_blender/, as Blender's add-on installer expects).
file(REMOVE_RECURSE ${STAGE}/relief_blender)
file(GLOB py ${SRC}/*.py)
file(COPY ${py} DESTINATION ${STAGE}/relief_blender)
file(GLOB pkg ${PKG}/*.py)
file(COPY ${pkg} ${MODULE} DESTINATION ${STAGE}/relief_blender/relief)
file(REMOVE ${ZIP})
execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${ZIP} --format=zip relief_blender
                WORKING_DIRECTORY ${STAGE} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "could not write ${ZIP}")
endif()
