# Sourced by the launchers (deploy/run.sh, deploy/test.sh): OpenBLAS 0.3.21
# chooses its kernels once, when a program loads it, and falls back to its
# oldest (Prescott) on CPUs newer than it. Names the kernels for this CPU's
# vector units unless OPENBLAS_CORETYPE is set (an operator's choice wins);
# oaipp-server logs the kernels it got (server/library_settings.h).
if [[ -z "${OPENBLAS_CORETYPE:-}" ]]; then
  _flags="$(grep -m1 '^flags' /proc/cpuinfo 2>/dev/null || true)"
  if [[ " $_flags " == *" avx512f "* && " $_flags " == *" avx512dq "* &&
        " $_flags " == *" avx512bw "* && " $_flags " == *" avx512vl "* ]]; then
    export OPENBLAS_CORETYPE=SkylakeX
  elif [[ " $_flags " == *" avx2 "* && " $_flags " == *" fma "* ]]; then
    export OPENBLAS_CORETYPE=Haswell
  fi
  unset _flags
fi
