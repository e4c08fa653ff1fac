/* Benchmark and evaluation harness for one generated flexgen C kernel.
 *
 * Compiled once per kernel by benchmarks/kernels.py (no -march, no -ffast-math):
 *
 *   gcc -O2 -std=c99 -I generated/c \
 *       -DKERNEL=scm3 -DKERNEL_UPPER=SCM3 '-DKERNEL_HEADER="scm3.h"' \
 *       benchmarks/c/harness.c generated/c/scm3.c -lm -o harness_scm3
 *
 * The kernel lives in its own translation unit (no LTO), so the compiler cannot inline it into
 * the timing loop or drop calls; every call's outputs also feed a checksum that is written to a
 * volatile sink and printed.  -DHARNESS_NO_FLOAT builds against a kernel without the float twin.
 *
 * Usage (q files are raw native doubles, M rows of KERNEL_N values):
 *   harness bench QFILE M REPEATS TARGET_MS
 *       cycles the M q's in a loop; each repeat runs long enough to take about TARGET_MS;
 *       prints "double <min ns per call>", "float <min ns per call>", "checksum <value>".
 *   harness eval QFILE M OUTFILE
 *       writes, as raw doubles: M rows of [pose(3) J(3N) H(3NN)] from the double kernel, the
 *       same M rows from the float kernel (widened), then M in_range flags (0.0 / 1.0).
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include KERNEL_HEADER

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define EVAL CAT(KERNEL, _evaluate)
#define EVAL_F CAT(KERNEL, _evaluate_f)
#define IN_RANGE CAT(KERNEL, _in_range)
#define NQ CAT(KERNEL_UPPER, _N)
#define NJ (3 * NQ)
#define NH (3 * NQ * NQ)
#define NOUT (3 + NJ + NH)

volatile double harness_sink;

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

/* iters passes over the m q's; returns elapsed ns, adds a checksum of the outputs to *acc */
static double run_double(long iters, int m, const double *q, double *acc)
{
    double pose[3], J[NJ], H[NH];
    double s = 0.0;
    double t0 = now_ns();
    for (long it = 0; it < iters; ++it) {
        for (int k = 0; k < m; ++k) {
            EVAL(q + (size_t)k * NQ, pose, J, H);
            s += pose[0] + pose[1] + J[NJ - 1 - NQ] + H[NH - 1 - NQ * NQ];
        }
    }
    double t1 = now_ns();
    *acc += s;
    return t1 - t0;
}

#ifndef HARNESS_NO_FLOAT
static double run_float(long iters, int m, const float *q, double *acc)
{
    float pose[3], J[NJ], H[NH];
    float s = 0.0f;
    double t0 = now_ns();
    for (long it = 0; it < iters; ++it) {
        for (int k = 0; k < m; ++k) {
            EVAL_F(q + (size_t)k * NQ, pose, J, H);
            s += pose[0] + pose[1] + J[NJ - 1 - NQ] + H[NH - 1 - NQ * NQ];
        }
    }
    double t1 = now_ns();
    *acc += s;
    return t1 - t0;
}
#endif

static double *read_q(const char *path, int m)
{
    FILE *f = fopen(path, "rb");
    if (!f) { perror(path); exit(2); }
    double *q = malloc(sizeof(double) * (size_t)m * NQ);
    if (!q || fread(q, sizeof(double), (size_t)m * NQ, f) != (size_t)m * NQ) {
        fprintf(stderr, "harness: cannot read %d x %d doubles from %s\n", m, NQ, path);
        exit(2);
    }
    fclose(f);
    return q;
}

static int bench(const double *q, int m, int repeats, double target_ms)
{
    double acc = 0.0;
    /* calibrate: grow iters until one repeat takes about target_ms */
    long iters = 1;
    double t;
    for (;;) {
        t = run_double(iters, m, q, &acc);
        if (t >= target_ms * 1e6 * 0.5 || iters > (1L << 40)) break;
        iters *= 2;
    }
    if (t > 0) iters = (long)(iters * (target_ms * 1e6 / t)) + 1;
    double best = 1e300;
    for (int r = 0; r < repeats; ++r) {
        t = run_double(iters, m, q, &acc) / ((double)iters * m);
        if (t < best) best = t;
    }
    printf("double %.6f\n", best);
#ifndef HARNESS_NO_FLOAT
    float *qf = malloc(sizeof(float) * (size_t)m * NQ);
    for (size_t i = 0; i < (size_t)m * NQ; ++i) qf[i] = (float)q[i];
    run_float(iters, m, qf, &acc);            /* warm-up */
    best = 1e300;
    for (int r = 0; r < repeats; ++r) {
        t = run_float(iters, m, qf, &acc) / ((double)iters * m);
        if (t < best) best = t;
    }
    printf("float %.6f\n", best);
    free(qf);
#endif
    harness_sink = acc;
    printf("checksum %.17g\n", harness_sink);
    return 0;
}

static int eval(const double *q, int m, const char *out_path)
{
    FILE *f = fopen(out_path, "wb");
    if (!f) { perror(out_path); return 2; }
    double *row = malloc(sizeof(double) * NOUT);
    for (int k = 0; k < m; ++k) {
        EVAL(q + (size_t)k * NQ, row, row + 3, row + 3 + NJ);
        fwrite(row, sizeof(double), NOUT, f);
    }
#ifndef HARNESS_NO_FLOAT
    float qf[NQ], rf[NOUT];
    for (int k = 0; k < m; ++k) {
        for (int i = 0; i < NQ; ++i) qf[i] = (float)q[(size_t)k * NQ + i];
        EVAL_F(qf, rf, rf + 3, rf + 3 + NJ);
        for (int i = 0; i < NOUT; ++i) row[i] = rf[i];
        fwrite(row, sizeof(double), NOUT, f);
    }
#else
    for (int i = 0; i < NOUT; ++i) row[i] = 0.0 / 0.0;
    for (int k = 0; k < m; ++k) fwrite(row, sizeof(double), NOUT, f);
#endif
    for (int k = 0; k < m; ++k) {
        double flag = IN_RANGE(q + (size_t)k * NQ) ? 1.0 : 0.0;
        fwrite(&flag, sizeof(double), 1, f);
    }
    free(row);
    return fclose(f) == 0 ? 0 : 2;
}

int main(int argc, char **argv)
{
    if (argc >= 6 && strcmp(argv[1], "bench") == 0) {
        int m = atoi(argv[3]);
        double *q = read_q(argv[2], m);
        int rc = bench(q, m, atoi(argv[4]), atof(argv[5]));
        free(q);
        return rc;
    }
    if (argc >= 5 && strcmp(argv[1], "eval") == 0) {
        int m = atoi(argv[3]);
        double *q = read_q(argv[2], m);
        int rc = eval(q, m, argv[4]);
        free(q);
        return rc;
    }
    fprintf(stderr, "usage: %s bench QFILE M REPEATS TARGET_MS | eval QFILE M OUTFILE\n", argv[0]);
    return 2;
}
