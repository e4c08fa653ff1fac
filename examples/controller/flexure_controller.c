/* A controller-side use of a generated kernel: one flexure of a finger, clamped at its root,
 * with a tip load measured by a force sensor (fx, fy, moment). Each control cycle solves the
 * equilibrium with the 3-mode polynomial kernel scm3 (Newton from the last cycle's answer, no
 * heap, no globals, fixed worst-case work), checks the kernel's range, and returns the tip pose
 * and the 2x2 tip compliance the impedance controller needs.
 *
 * Build:  gcc -std=c99 -Wall -Wextra -Werror -pedantic -O2 -I../../generated/c \
 *             flexure_controller.c ../../generated/c/scm3.c -lm -o flexure_controller
 * Run:    ./flexure_controller L EI fx fy moment     (defaults: 1 1 0 -2 0, Bisshopp alpha = 2)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "scm3.h"

#define N SCM3_N

typedef struct {
    double length, EI;          /* flexure length and bending stiffness */
} Flexure;

typedef struct {
    double q[N];                /* Legendre curvature coefficients (dimensionless) */
    double pose[3];             /* tip x, y (length units) and angle */
    double compliance[2][2];    /* d(tip position)/d(tip force) at the equilibrium */
    int iterations;
    int converged;              /* residual below tolerance within the iteration budget */
    int in_range;               /* the polynomial kernel is valid at q (|phi| <= 90 deg) */
} TipState;

/* Solve the 3x3 system A x = b by Gaussian elimination with partial pivoting (A, b destroyed). */
static int solve3(double A[N][N], double b[N], double x[N])
{
    int i, j, k;
    for (k = 0; k < N; ++k) {
        int p = k;
        for (i = k + 1; i < N; ++i) if (fabs(A[i][k]) > fabs(A[p][k])) p = i;
        if (A[p][k] == 0.0) return 0;
        for (j = 0; j < N; ++j) { double t = A[k][j]; A[k][j] = A[p][j]; A[p][j] = t; }
        { double t = b[k]; b[k] = b[p]; b[p] = t; }
        for (i = k + 1; i < N; ++i) {
            double f = A[i][k] / A[k][k];
            for (j = k; j < N; ++j) A[i][j] -= f * A[k][j];
            b[i] -= f * b[k];
        }
    }
    for (i = N - 1; i >= 0; --i) {
        double s = b[i];
        for (j = i + 1; j < N; ++j) s -= A[i][j] * x[j];
        x[i] = s / A[i][i];
    }
    return 1;
}

/* Residual r = grad U - J^T F and stiffness K = hess U - H^T F at q, for load (fx, fy, m). */
static void residual(const Flexure *f, const double load[3], const double q[N],
                     double pose[3], double J[3 * N], double r[N], double K[N][N])
{
    double H[3 * N * N];
    const double F[3] = {load[0] * f->length, load[1] * f->length, load[2]};  /* x, y scaled by L */
    int i, j, row;
    scm3_evaluate(q, pose, J, H);
    for (i = 0; i < N; ++i) {
        double k_elastic = f->EI / f->length / (2.0 * i + 1.0);   /* U = EI/2L sum q_n^2/(2n+1) */
        r[i] = k_elastic * q[i];
        for (j = 0; j < N; ++j) K[i][j] = (i == j) ? k_elastic : 0.0;
        for (row = 0; row < 3; ++row) {
            r[i] -= F[row] * J[row * N + i];
            for (j = 0; j < N; ++j) K[i][j] -= F[row] * H[(row * N + i) * N + j];
        }
    }
}

/* One control cycle: Newton from state->q (the last cycle's answer), at most max_iter steps. */
static void solve_tip_load(const Flexure *f, const double load[3], TipState *state, int max_iter)
{
    double J[3 * N], r[N], K[N][N], dq[N];
    const double scale = f->EI / f->length + fabs(load[0] * f->length) + fabs(load[1] * f->length)
                         + fabs(load[2]);
    int i, it;
    state->converged = 0;
    for (it = 0; it < max_iter; ++it) {
        double norm = 0.0;
        residual(f, load, state->q, state->pose, J, r, K);
        for (i = 0; i < N; ++i) norm = fmax(norm, fabs(r[i]));
        if (norm <= 1e-12 * scale) { state->converged = 1; break; }
        for (i = 0; i < N; ++i) r[i] = -r[i];
        if (!solve3(K, r, dq)) break;
        for (i = 0; i < N; ++i) state->q[i] += dq[i];
    }
    state->iterations = it;
    residual(f, load, state->q, state->pose, J, r, K);
    state->pose[0] *= f->length;
    state->pose[1] *= f->length;
    state->in_range = scm3_in_range(state->q);
    /* compliance C = Jp K^-1 Jp^T, Jp the position rows of the tip Jacobian (length units) */
    {
        int a, b2;
        for (a = 0; a < 2; ++a) {
            double Kc[N][N], rhs[N], x[N];
            int m, n;
            for (m = 0; m < N; ++m) {
                for (n = 0; n < N; ++n) Kc[m][n] = K[m][n];
                rhs[m] = J[a * N + m] * f->length;
            }
            solve3(Kc, rhs, x);
            for (b2 = 0; b2 < 2; ++b2) {
                double s = 0.0;
                for (m = 0; m < N; ++m) s += J[b2 * N + m] * f->length * x[m];
                state->compliance[b2][a] = s;
            }
        }
    }
}

int main(int argc, char **argv)
{
    Flexure flexure = {1.0, 1.0};
    double load[3] = {0.0, -2.0, 0.0};
    TipState state = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {{0.0, 0.0}, {0.0, 0.0}}, 0, 0, 0};
    const int ramp = 10;        /* the first cycles ramp the sensed load in, as a real start-up */
    int k, i;
    if (argc == 6) {
        flexure.length = atof(argv[1]);
        flexure.EI = atof(argv[2]);
        for (i = 0; i < 3; ++i) load[i] = atof(argv[3 + i]);
    } else if (argc != 1) {
        fprintf(stderr, "usage: %s [L EI fx fy moment]\n", argv[0]);
        return 2;
    }
    for (k = 1; k <= ramp; ++k) {
        double partial[3];
        for (i = 0; i < 3; ++i) partial[i] = load[i] * k / ramp;
        solve_tip_load(&flexure, partial, &state, 20);
    }
    printf("{\"converged\": %d, \"in_range\": %d, \"iterations\": %d, "
           "\"q\": [%.17g, %.17g, %.17g], \"pose\": [%.17g, %.17g, %.17g], "
           "\"compliance\": [[%.17g, %.17g], [%.17g, %.17g]]}\n",
           state.converged, state.in_range, state.iterations,
           state.q[0], state.q[1], state.q[2], state.pose[0], state.pose[1], state.pose[2],
           state.compliance[0][0], state.compliance[0][1],
           state.compliance[1][0], state.compliance[1][1]);
    return state.converged && state.in_range ? 0 : 1;
}
