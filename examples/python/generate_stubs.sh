#!/usr/bin/env bash
# Generates the Python stubs of the oaipp.v1 API into OUT (default
# build/python): the messages (protoc's Python output) and the service stubs
# (gRPC's Python plugin). Debian 12's python3-grpc-tools predates proto3
# `optional`, which the API uses, so the system protoc and
# /usr/bin/grpc_python_plugin (from protobuf-compiler-grpc) do the work.
#
#   bash examples/python/generate_stubs.sh build/python
#   PYTHONPATH=build/python python3 -c "from oaipp.v1 import mission_service_pb2"
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
out="${1:-$root/build/python}"
plugin="${GRPC_PYTHON_PLUGIN:-/usr/bin/grpc_python_plugin}"
if [ ! -x "$plugin" ]; then
  echo "generate_stubs: $plugin not found (apt-get install protobuf-compiler-grpc)" >&2
  exit 1
fi
mkdir -p "$out"
protoc -I "$root/proto" --python_out="$out" --grpc_out="$out" \
  --plugin=protoc-gen-grpc="$plugin" \
  oaipp/v1/mission_service.proto oaipp/v1/scenario.proto
