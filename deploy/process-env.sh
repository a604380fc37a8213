# Sourced by the launchers (deploy/run.sh via serve.sh, deploy/test.sh,
# deploy/experiments.sh): what a program must find in its environment when
# it starts, because the libraries read it only then. An operator's own
# value of either variable wins.
#
# OpenBLAS 0.3.21 chooses its kernels once, when a program loads it, and
# falls back to its oldest (Prescott) on CPUs newer than it: name the
# kernels for this CPU's vector units (oaipp-server logs the kernels it
# got, server/library_settings.h).
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

# glibc's malloc backs its large blocks (a mission's 20 MB covariance and
# its copies) with transparent huge pages where the kernel offers them on
# request (madvise): a fleet's first measurements copy 100 such maps at
# once, and with 4 KB pages those copies and their page faults took a third
# of the CPU of that burst (docs/capacity.md "Huge pages").
if [[ -z "${GLIBC_TUNABLES:-}" ]]; then
  export GLIBC_TUNABLES=glibc.malloc.hugetlb=1
fi
