# Included by the message packages here after their find_package() of what they depend on,
# before rosidl_generate_interfaces(): only the generators a Python node uses run (the C and
# Python generators, the C type supports), not the C++ ones that those packages' configs find
# too (their code would be compiled for nothing: about half the build).
foreach(generator rosidl_cmake rosidl_generator_type_description rosidl_generator_c
    rosidl_typesupport_introspection_c rosidl_typesupport_fastrtps_c rosidl_typesupport_c
    rosidl_generator_py)
  find_package(${generator} REQUIRED)
endforeach()
list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "_cpp:")
