# The number of ODE models in THE list, include/eci/models/list.hpp (ode_models, one type per line), so that the
# CLI and the Python module can make one translation unit per model (tuple_element_t<I, ode_models>) and compile
# them in parallel. The list itself stays C++: the generated units check this count with a static_assert, and
# editing the header re-runs CMake.
function(eci_ode_model_count out)
  set(header ${PROJECT_SOURCE_DIR}/include/eci/models/list.hpp)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${header})
  file(READ ${header} text)
  if(NOT text MATCHES "using ode_models = std::tuple<\n([^;]*)>;")
    message(FATAL_ERROR "${header}: no 'using ode_models = std::tuple<' followed by one model type per line")
  endif()
  string(REGEX MATCHALL "\n" breaks "${CMAKE_MATCH_1}")
  list(LENGTH breaks count)
  math(EXPR count "${count} + 1")
  set(${out} ${count} PARENT_SCOPE)
endfunction()
