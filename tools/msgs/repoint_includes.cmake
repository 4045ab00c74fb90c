# The PyPI wheels' exported CMake targets name the include directories of the machine that built
# them (/opt/python/...: its Python and numpy headers). Point every imported target of this
# directory at this venv's Python and numpy instead, before CMake checks that they exist.
get_directory_property(imported IMPORTED_TARGETS)
foreach(target IN LISTS imported)
  get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  if(dirs AND dirs MATCHES "/opt/python/")
    list(FILTER dirs EXCLUDE REGEX "^/opt/python/")
    list(APPEND dirs ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${dirs}")
  endif()
endforeach()
