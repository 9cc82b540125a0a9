#!/usr/bin/env bash
# Measures this x86-64 CPU's peak rate of 256-bit (AVX2) vector operations on
# one core, and its clock, with loops of independent register-to-register
# instructions written in assembly (so no compiler can change them):
#
#   scripts/vector-peak.sh
#
# docs/benchmark-history.md ("Curl-noise flow": "The floor on this VM")
# divides the flow noise's count of 256-bit operations per particle-step by
# the mixed rate printed here to get the least CPU time per particle-step
# any schedule could reach on the machine. Zen 1 runs each 256-bit
# operation as two 128-bit halves on four 128-bit pipes (two of them add,
# two multiply), so it peaks at two 256-bit operations per cycle, one of
# them an add; Zen 2 and later have 256-bit pipes and twice that. Needs a C
# compiler (cc) and a CPU with AVX2.
set -euo pipefail
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/peak.c" <<'EOF'
#include <stdio.h>
#include <time.h>

static double seconds(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

#define ROUNDS 100000000L
#define CLOBBERS "xmm0", "xmm1", "xmm2", "xmm3", "xmm4", "xmm5", "xmm6", "xmm7"

/* Eight independent instructions per round, each on its own register. */
#define RATE(label, body)                                           \
  do {                                                              \
    double start = seconds();                                       \
    for (long n = 0; n < ROUNDS; n++) __asm__ volatile(body ::: CLOBBERS); \
    double per_ns = 8.0 * ROUNDS / (seconds() - start) / 1e9;       \
    printf("%-44s %5.2f per ns, %4.2f per cycle\n", label, per_ns, per_ns / ghz); \
  } while (0)

int main(void) {
  /* The clock: a chain of dependent integer adds runs one per cycle. */
  long chain = 0;
  double start = seconds();
  for (long n = 0; n < ROUNDS; n++)
    __asm__ volatile("add $1, %0\n add $1, %0\n add $1, %0\n add $1, %0" : "+r"(chain));
  double ghz = 4.0 * ROUNDS / (seconds() - start) / 1e9;
  printf("clock (dependent integer adds)               %5.2f GHz\n", ghz);
  RATE("256-bit float adds (vaddps)",
       "vaddps %%ymm15,%%ymm0,%%ymm0\n vaddps %%ymm15,%%ymm1,%%ymm1\n"
       "vaddps %%ymm15,%%ymm2,%%ymm2\n vaddps %%ymm15,%%ymm3,%%ymm3\n"
       "vaddps %%ymm15,%%ymm4,%%ymm4\n vaddps %%ymm15,%%ymm5,%%ymm5\n"
       "vaddps %%ymm15,%%ymm6,%%ymm6\n vaddps %%ymm15,%%ymm7,%%ymm7\n");
  RATE("256-bit adds, multiplies, xors and ands",
       "vaddps %%ymm15,%%ymm0,%%ymm0\n vmulps %%ymm15,%%ymm1,%%ymm1\n"
       "vpxor %%ymm14,%%ymm2,%%ymm2\n vandps %%ymm15,%%ymm3,%%ymm3\n"
       "vaddps %%ymm15,%%ymm4,%%ymm4\n vmulps %%ymm15,%%ymm5,%%ymm5\n"
       "vpxor %%ymm14,%%ymm6,%%ymm6\n vandps %%ymm15,%%ymm7,%%ymm7\n");
  return (int)(chain & 1);
}
EOF
cc -O2 -o "$work/peak" "$work/peak.c"
"$work/peak"
