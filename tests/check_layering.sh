#!/usr/bin/env bash
# Who may use whom: the table in README.md, "Modules: who may include whom",
# held to every #include of a project header in the modules' sources (.h,
# .cc) and to every library in their CMake target_link_libraries lines.
# Prints one line per violation (file:line, what is included or linked, the
# rule it breaks) and exits 1; exits 0 when every module keeps to its row.
#   bash tests/check_layering.sh [repository root]
#   bash tests/check_layering.sh --self-test [repository root]
#     checks a copy of the tree with a bad include and a bad link planted in
#     it, and fails unless exactly those two are reported.
set -uo pipefail

# The README's table, row for row: a module and the modules it may use
# besides itself; last column, the external libraries that the text under
# the table keeps out of it. Naming a module covers its parts that are not
# rows of their own: core covers core/common; client does not cover
# client/cli, which has its own row.
# proto(scenario) is scenario.proto, "apart" from the rest of proto/.
export LAYERING_RULES='
# module     | may use                        | must not use
core         | -                              | grpc protobuf opencv-in-headers
render       | core/common                    | grpc protobuf
proto        | -                              | -
api          | core proto                     | opencv
server       | api core render proto          | -
sim          | api core proto(scenario)       | -
client       | api proto                      | -
client/cli   | client sim render api core proto | -
'

# Where each module is: a path from the root, or a header as included
# (the generated code is included as oaipp/...). The longest prefix wins.
export LAYERING_WHERE='
core/common/               core/common
core/                      core
render/                    render
proto/oaipp/v1/scenario.   proto(scenario)
oaipp/v1/scenario.         proto(scenario)
proto/                     proto
oaipp/                     proto
api/                       api
server/                    server
sim/                       sim
client/cli/                client/cli
client/                    client
'

# External libraries named in the last column: header prefixes | link names.
# "opencv-in-headers" is OpenCV in a header or in a PUBLIC/INTERFACE link.
export LAYERING_EXTERNAL='
grpc       | grpcpp/ grpc/ grpc++/   | gRPC::
protobuf   | google/protobuf/        | protobuf::
opencv     | opencv2/ opencv/        | oaipp::opencv oaipp_opencv opencv_
'

module_dirs=(core render proto api server sim client)

# Tables and the rule test, shared by the two passes below.
read -r -d '' AWK_LIB <<'EOF'
function trim(s) { gsub(/^[ \t]+|[ \t]+$/, "", s); return s }
function load(   n, l, i, f, k) {
  n = split(ENVIRON["LAYERING_RULES"], l, "\n")
  for (i = 1; i <= n; i++) {
    if (l[i] ~ /^[ \t]*(#|$)/) continue
    split(l[i], f, "|"); k = trim(f[1])
    R[k] = trim(f[2]); if (R[k] == "-") R[k] = ""
    NEVER[k] = trim(f[3]); if (NEVER[k] == "-") NEVER[k] = ""
  }
  n = split(ENVIRON["LAYERING_WHERE"], l, "\n")
  for (i = 1; i <= n; i++) {
    if (l[i] ~ /^[ \t]*(#|$)/) continue
    split(trim(l[i]), f, /[ \t]+/); W[f[1]] = f[2]
  }
  n = split(ENVIRON["LAYERING_EXTERNAL"], l, "\n")
  for (i = 1; i <= n; i++) {
    if (l[i] ~ /^[ \t]*(#|$)/) continue
    split(l[i], f, "|"); k = trim(f[1]); EH[k] = trim(f[2]); EL[k] = trim(f[3])
  }
}
# The module a path or an included header belongs to; "" when none.
function unit_of(p,   k, best, bl) {
  best = ""; bl = 0
  for (k in W) if (index(p, k) == 1 && length(k) > bl) { best = W[k]; bl = length(k) }
  return best
}
# The table row that governs a module or a part of one.
function row_of(u,   r, best, bl) {
  if (u in R) return u
  best = ""; bl = 0
  for (r in R) if ((index(u, r "/") == 1 || index(u, r "(") == 1) && length(r) > bl) { best = r; bl = length(r) }
  return best
}
function may_use(r, u,   n, g, i) {
  if (row_of(u) == r) return 1
  n = split(R[r], g, " ")
  for (i = 1; i <= n; i++) {
    if (u == g[i]) return 1
    if (index(u, g[i] "/") == 1 && !(u in R)) return 1
  }
  return 0
}
function rule(r,   s) {
  s = R[r]; gsub(/ /, ", ", s)
  return "README: " r " may use " (s == "" ? "no other module" : "only " s)
}
# The external library a header (kind "h") or a link name (kind "l") is of.
function family(name, kind,   f, n, p, i) {
  for (f in EH) {
    n = split(kind == "h" ? EH[f] : EL[f], p, " ")
    for (i = 1; i <= n; i++) if (index(name, p[i]) == 1) return f
  }
  return ""
}
# Whether row r must not use external library f; exposed: in a header or a
# PUBLIC/INTERFACE link.
function never(r, f, exposed,   n, g, i) {
  if (f == "") return 0
  n = split(NEVER[r], g, " ")
  for (i = 1; i <= n; i++)
    if (g[i] == f || (g[i] == f "-in-headers" && exposed)) return g[i]
  return 0
}
function report(where, what) {
  printf "%s: %s\n", where, what; bad++
}
EOF

# Pass 1: every #include in the modules' sources ("file:line:text" lines).
read -r -d '' AWK_INCLUDES <<'EOF'
function normal(p,   n, s, o, i, k) {
  n = split(p, s, "/"); k = 0
  for (i = 1; i <= n; i++) {
    if (s[i] == "." || s[i] == "") continue
    if (s[i] == ".." && k > 0) { k--; continue }
    o[++k] = s[i]
  }
  p = ""; for (i = 1; i <= k; i++) p = p (i > 1 ? "/" : "") o[i]
  return p
}
BEGIN { load() }
{
  file = $0; sub(/:.*/, "", file)
  rest = substr($0, length(file) + 2); line = rest; sub(/:.*/, "", line)
  text = substr(rest, length(line) + 2)
  if (!match(text, /^[ \t]*#[ \t]*include[ \t]*["<][^">]+[">]/)) next
  inc = substr(text, RSTART, RLENGTH); sub(/^[^"<]*["<]/, "", inc); sub(/[">]$/, "", inc)
  if (inc ~ /^\.\.?\//) { dir = file; sub(/\/[^\/]*$/, "", dir); inc = normal(dir "/" inc) }
  r = row_of(unit_of(file)); if (r == "") next
  u = unit_of(inc)
  if (u != "" && !may_use(r, u))
    report(file ":" line, r " includes \"" inc "\" (" u "); " rule(r))
  f = family(inc, "h"); g = never(r, f, file ~ /\.(h|hpp)$/)
  if (u == "" && g)
    report(file ":" line, r " includes \"" inc "\" (" f "); README: " r " must not use " g)
}
END { exit bad > 0 }
EOF

# Pass 2: the CMake files, read as statements (command, arguments with their
# lines); then add_library / add_executable / oaipp_grpc_proto_library name
# the targets' modules and every target_link_libraries item is checked.
read -r -d '' AWK_CMAKE <<'EOF'
function flush() {
  if (tok == "") return
  if (tok ~ /^".*"$/) tok = substr(tok, 2, length(tok) - 2)
  if (depth == 0) pending = tok
  else { SN[ns]++; ST[ns, SN[ns]] = tok; STL[ns, SN[ns]] = tl }
  tok = ""
}
BEGIN { load() }
FNR == 1 { flush(); depth = 0; inq = 0; pending = "" }
{
  s = $0; n = length(s)
  for (i = 1; i <= n; i++) {
    c = substr(s, i, 1)
    if (inq) {
      tok = tok c
      if (c == "\\") { i++; tok = tok substr(s, i, 1) } else if (c == "\"") inq = 0
      continue
    }
    if (c == "\"") { if (tok == "") tl = FNR; tok = tok c; inq = 1; continue }
    if (c == "#") break
    if (c == " " || c == "\t" || c == "\r") { flush(); continue }
    if (c == "(") {
      flush()
      if (depth == 0) {
        ns++; SC[ns] = tolower(pending); SF[ns] = FILENAME; SN[ns] = 0; pending = ""
        d = FILENAME; sub(/\/[^\/]*$/, "", d); SD[ns] = d
      }
      depth++; continue
    }
    if (c == ")") { flush(); if (depth > 0) depth--; continue }
    if (tok == "") tl = FNR
    tok = tok c
  }
  if (inq) tok = tok "\n"; else flush()
}
function resolve(t,   k) { k = 0; while ((t in ALIAS) && k++ < 8) t = ALIAS[t]; return t }
END {
  for (k = 1; k <= ns; k++) {
    c = SC[k]; name = ST[k, 1]
    if (c != "add_library" && c != "add_executable" && c != "oaipp_grpc_proto_library") continue
    if (ST[k, 2] == "ALIAS") { ALIAS[name] = ST[k, 3]; continue }
    u = ""; key = ""
    for (j = 2; j <= SN[k]; j++) {
      if (ST[k, j] == "IMPORTED") break
      if (c == "oaipp_grpc_proto_library" && ST[k, j - 1] == "PROTOS") { u = unit_of(ST[k, j]); key = "x"; break }
      if (c != "oaipp_grpc_proto_library" && ST[k, j] ~ /^[^$\/].*\.(cc|cpp|cxx|c|h|hpp)$/) {
        u = unit_of(SD[k] "/" ST[k, j]); key = "x"; break
      }
    }
    # No sources (an INTERFACE library): oaipp_common in core/ is core/common.
    if (key == "" && ST[k, j] != "IMPORTED") { t = name; sub(/^oaipp_/, "", t); u = unit_of(SD[k] "/" t "/") }
    UNIT[name] = u; DEFINED[name] = 1
  }
  for (k = 1; k <= ns; k++) {
    if (SC[k] != "target_link_libraries") continue
    tgt = resolve(ST[k, 1])
    uu = (tgt in DEFINED && UNIT[tgt] != "") ? UNIT[tgt] : unit_of(SD[k] "/")
    r = row_of(uu); if (r == "") continue
    exposed = 1
    for (j = 2; j <= SN[k]; j++) {
      item = ST[k, j]; where = SF[k] ":" STL[k, j]
      if (item ~ /^(PUBLIC|INTERFACE|LINK_PUBLIC|LINK_INTERFACE_LIBRARIES)$/) { exposed = 1; continue }
      if (item ~ /^(PRIVATE|LINK_PRIVATE)$/) { exposed = 0; continue }
      if (item ~ /^(debug|optimized|general)$/) continue
      if (item ~ /^\$</) {  # $<...:name>: the name
        sub(/>+$/, "", item)
        item = match(item, /[A-Za-z_][A-Za-z0-9_.+-]*(::[A-Za-z0-9_.+-]+)*$/) ? substr(item, RSTART) : ""
      }
      if (item == "" || item ~ /^\$\{/) continue
      lib = resolve(item)
      if ((lib in DEFINED) && UNIT[lib] != "") {
        if (!may_use(r, UNIT[lib]))
          report(where, ST[k, 1] " (" r ") links " item " (" UNIT[lib] "); " rule(r))
        continue
      }
      f = family(item, "l"); if (f == "") f = family(lib, "l")
      if ((g = never(r, f, exposed)))
        report(where, ST[k, 1] " (" r ") links " item " (" f "); README: " r " must not use " g)
      else if (!(lib in DEFINED) && f == "" && item ~ /^oaipp(::|_)/)
        report(where, ST[k, 1] " (" r ") links " item ", which no add_library of the project defines")
    }
  }
  exit bad > 0
}
EOF

check() {
  local root="$1" st=0 dirs=() d
  cd "$root" || return 2
  for d in "${module_dirs[@]}"; do [ -d "$d" ] && dirs+=("$d"); done
  [ "${#dirs[@]}" -gt 0 ] || { echo "layering: no module folders under $root" >&2; return 2; }
  grep -rnE --include='*.h' --include='*.cc' --include='*.hpp' --include='*.cpp' \
      '^[[:space:]]*#[[:space:]]*include' "${dirs[@]}" | sort -t: -k1,1 -k2,2n |
    awk "$AWK_LIB"$'\n'"$AWK_INCLUDES" || st=1
  { find "${dirs[@]}" \( -name CMakeLists.txt -o -name '*.cmake' \) -print
    [ -d cmake ] && find cmake -name '*.cmake' -print; } | sort |
    { mapfile -t files; awk "$AWK_LIB"$'\n'"$AWK_CMAKE" "${files[@]}"; } || st=1
  return "$st"
}

self_test() {
  local src="$1" tmp before after new status=1
  tmp=$(mktemp -d) || return 2
  (cd "$src" && find "${module_dirs[@]}" cmake \( -name '*.h' -o -name '*.cc' \
      -o -name CMakeLists.txt -o -name '*.cmake' \) -exec cp --parents -t "$tmp" {} +) || return 2
  before=$( (check "$tmp") )
  printf '// planted by check_layering.sh --self-test\n#include "server/service.h"\n' \
    > "$tmp/render/planted.cc"
  printf '\ntarget_link_libraries(oaipp_render PRIVATE oaipp::server)\n' >> "$tmp/render/CMakeLists.txt"
  local want_inc="render/planted.cc:2: " want_lib
  want_lib="render/CMakeLists.txt:$(wc -l < "$tmp/render/CMakeLists.txt"): "
  after=$( (check "$tmp") )
  new=$(comm -13 <(sort <<<"$before") <(sort <<<"$after"))
  rm -rf "$tmp"
  if [ "$(grep -c . <<<"$new")" -eq 2 ] && grep -qF "$want_inc" <<<"$new" &&
     grep -qF "$want_lib" <<<"$new"; then
    status=0; echo "layering self-test: the planted include and link are both reported:"
  else
    echo "layering self-test FAILED: expected exactly ${want_inc% } and ${want_lib% }, new reports:"
  fi
  printf '%s\n' "$new"
  return "$status"
}

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "${1:-}" = "--self-test" ]; then
  self_test "${2:-$here}"; exit $?
fi
out=$( (check "${1:-$here}") ); st=$?
if [ -n "$out" ]; then printf '%s\n' "$out"; fi
if [ "$st" -eq 0 ]; then
  echo "layering: every module includes and links only what README's table allows"
elif [ "$st" -eq 1 ]; then
  echo "layering: $(grep -c . <<<"$out") violation(s) of README's \"Modules: who may include whom\""
fi
exit "$st"
