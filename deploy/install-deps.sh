#!/usr/bin/env bash
# Installs every Debian 12 package the project needs to build, test and run.
# Idempotent: packages already present are skipped, and nothing is printed
# when the machine has everything.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake pkg-config git
  # a faster linker and a build tool that keeps both cores busy, for the
  # test builds, and the formatter their first stage checks (deploy/test.sh)
  lld ninja-build clang-format
  # core: linear algebra, exact collision geometry, camera model, CMA-ES
  libeigen3-dev libfcl-dev libccd-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-calib3d-dev libopencv-imgcodecs-dev
  libopencv-videoio-dev
  # the map pictures' PNG bytes (the server needs no OpenCV image codecs)
  libpng-dev
  libpagmo-dev libboost-serialization-dev libtbb-dev
  # Owen's T function for the confirmation objective (Boost.Math, headers only)
  libboost-dev
  libabsl-dev
  # large fields: the sparse-precision map's Cholesky factor (CHOLMOD)
  libsuitesparse-dev
  # service: gRPC + protobuf (plugin and library must come together), logs, metrics, JSON
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libspdlog-dev prometheus-cpp-dev nlohmann-json3-dev
  # durable missions: the embedded store and its command-line tool for backups;
  # PostgreSQL for several servers (the server library, and PostgreSQL 15 itself,
  # which the tests start in a temporary folder)
  libsqlite3-dev sqlite3 libpqxx-dev libpq-dev postgresql-15 postgresql-client-15
  # who gets in: token hashes (libssl's SHA-256), and openssl to make test certificates
  libssl-dev openssl
  # a fleet past one machine: the gRPC-aware proxy in front of the replicas
  # (deploy/cluster/, the cluster tests), and YAML for the offline check of
  # the Kubernetes manifests (deploy/k8s/)
  haproxy python3-yaml
  # ground stations: WGS84 <-> local ENU conversions; the Python example
  # client (its stubs come from the system protoc + grpc_python_plugin); a
  # headless browser for the live mission view's test
  libgeographiclib-dev python3-grpcio python3-protobuf chromium python3-websocket
  # the live mission view's small HTTP server
  libcpp-httplib-dev
  # the Kalman update's rank-m product on the CPU's own vector units
  # (core/mapping/dense_backend.h). The pthreads build, not the serial one:
  # the server calls it from several threads and the serial build's buffer
  # pool has no lock.
  libopenblas-pthread-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # fuzzing (fuzz/run.sh): clang, with libFuzzer and the sanitizer runtimes
  clang libclang-rt-14-dev
  # figures
  python3-matplotlib python3-numpy
  # the SAREnv benchmark (client/sarenv/): GEOS for the area a search covers
  # (buffered paths, as the benchmark measures it), PROJ and its database
  # for the datasets' UTM frames; GEOS also checks and rasterises search
  # areas (api/search_area.h)
  libgeos-dev libproj-dev proj-data
  # a search team's map files (client/geo_import/): GeoJSON, KML, GeoPackage through GDAL
  libgdal-dev
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: need root to install: ${missing[*]}" >&2
  exit 1
fi
echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
