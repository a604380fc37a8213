# oaipp_grpc_proto_library(NAME ROOT dir PROTOS a.proto ...)
# Generates C++ protobuf and gRPC code for PROTOS (paths relative to ROOT)
# into the build tree and builds it as static library NAME. Generated code is
# never committed. Needs find_package(Protobuf) and find_package(gRPC CONFIG)
# at the top level (imported targets are scoped to the directory that finds them).
function(oaipp_grpc_proto_library name)
  cmake_parse_arguments(ARG "" "ROOT" "PROTOS" ${ARGN})
  set(gen ${CMAKE_CURRENT_BINARY_DIR}/gen)
  file(MAKE_DIRECTORY ${gen})
  get_target_property(plugin gRPC::grpc_cpp_plugin LOCATION)
  set(srcs)
  foreach(proto ${ARG_PROTOS})
    string(REGEX REPLACE "\\.proto$" "" stem ${proto})
    set(outputs ${gen}/${stem}.pb.cc ${gen}/${stem}.pb.h ${gen}/${stem}.grpc.pb.cc ${gen}/${stem}.grpc.pb.h)
    add_custom_command(
      OUTPUT ${outputs}
      COMMAND ${Protobuf_PROTOC_EXECUTABLE} --proto_path=${ARG_ROOT} --cpp_out=${gen}
              --grpc_out=${gen} --plugin=protoc-gen-grpc=${plugin} ${ARG_ROOT}/${proto}
      DEPENDS ${ARG_ROOT}/${proto}
      COMMENT "Generating C++ code for ${proto}")
    list(APPEND srcs ${gen}/${stem}.pb.cc ${gen}/${stem}.grpc.pb.cc)
  endforeach()
  add_library(${name} STATIC ${srcs})
  target_include_directories(${name} PUBLIC ${gen})
  target_link_libraries(${name} PUBLIC protobuf::libprotobuf gRPC::grpc++)
  target_compile_options(${name} PRIVATE -w)  # generated code is not ours to warn about
endfunction()
