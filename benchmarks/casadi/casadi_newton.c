/* The CasADi peer's solver: a hand-written damped Newton around one fused CasADi kernel.
 *
 * peer_casadi.h (written by benchmarks/casadi_peer.py into its temporary folder) includes the
 * generated kernel's header and defines the sizes, the kernel's name, the diagonal elastic
 * stiffness and the two inputs (the scene's loads and tensions, and them times 1.01). The
 * kernel maps (q, inputs) to the potential Pi, its gradient r, its Hessian K (dense, n x n),
 * the output poses (3 per output) and their Jacobians, transposed (n x 3 per output: column c
 * of that n x 3 nout matrix, stored column-major, is row c of the Jacobian G).
 *
 * Newton from q (0 cold, the previous answer warm): stop at a relative residual
 * max|r| / max(max|grad U|, max|r - grad U|) <= 1e-12 or a step below 1e-14; the step
 * -K^-1 r by a Cholesky factorization K = L D L^T (of K + mu diag(stiffness), mu doubling from
 * 1e-3, where K is not positive definite), backtracked by halving until the potential falls by Armijo's rule (1e-4) or the
 * residual falls. The trial state's kernel call is the next iteration's: no call is repeated.
 * Then, with the factors of K at the answer, the compliance of each output
 * C = G K^-1 G^T = (L^-1 G^T)^T D^-1 (L^-1 G^T) for its first PEER_ROWS pose rows.
 */
#include <math.h>
#include <string.h>

#include "peer.h"
#include "peer_casadi.h"

#define N PEER_NDOF
#define NOUT PEER_NOUT
#define ROWS PEER_ROWS
#define TOL 1e-12
#define STEP_TOL 1e-14
#define MAX_ITERATIONS 50
#define MAX_HALVINGS 30
#define ARMIJO 1e-4

typedef struct {
    double q[N];
    double Pi, r[N], K[N * N], pose[3 * NOUT], GT[N * 3 * NOUT];
} state;

static state states[2];
static state *answer_state = &states[0];
static double q_kept[N];
static double compliance[NOUT][ROWS][ROWS];
static int iterations, calls, stable;
static casadi_int iw[PEER_SZ_IW + 1];
static double w[PEER_SZ_W + 1];

static void evaluate(state *s, const double *u)
{
    const double *arg[2];
    double *res[5];
    arg[0] = s->q;
    arg[1] = u;
    res[0] = &s->Pi;
    res[1] = s->r;
    res[2] = s->K;
    res[3] = s->pose;
    res[4] = s->GT;
    PEER_KERNEL(arg, res, iw, w, 0);
    ++calls;
}

static double max_abs(const double *x)
{
    double m = 0.0;
    int i;
    for (i = 0; i < N; ++i)
        if (fabs(x[i]) > m)
            m = fabs(x[i]);
    return m;
}

static double relative_residual(const state *s)
{
    double g = 0.0, f = 0.0, scale;
    int i;
    for (i = 0; i < N; ++i) {
        double gu = peer_stiffness[i] * s->q[i];
        if (fabs(gu) > g)
            g = fabs(gu);
        if (fabs(s->r[i] - gu) > f)
            f = fabs(s->r[i] - gu);
    }
    scale = g > f ? g : f;
    if (max_abs(s->r) == 0.0)
        return 0.0;
    return scale > 0.0 ? max_abs(s->r) / scale : INFINITY;
}

/* K + mu diag(stiffness) = L D L^T: L unit lower triangular (row-major, below the diagonal),
 * inv_d = 1 / D; 0 if not positive definite */
static int factor(const double *K, double mu, double *L, double *inv_d)
{
    double v[N], dk[N];
    int i, j, k;
    for (j = 0; j < N; ++j) {
        double d = K[j * N + j] + mu * peer_stiffness[j];
        for (k = 0; k < j; ++k) {
            v[k] = L[j * N + k] * dk[k];
            d -= L[j * N + k] * v[k];
        }
        if (!(d > 0.0))
            return 0;
        dk[j] = d;
        inv_d[j] = 1.0 / d;
        for (i = j + 1; i < N; ++i) {
            double s = K[i * N + j];
            for (k = 0; k < j; ++k)
                s -= L[i * N + k] * v[k];
            L[i * N + j] = s * inv_d[j];
        }
    }
    return 1;
}

/* y = L^-1 b (L unit lower) */
static void forward(const double *L, const double *b, double *y)
{
    int i, k;
    for (i = 0; i < N; ++i) {
        double s = b[i];
        for (k = 0; k < i; ++k)
            s -= L[i * N + k] * y[k];
        y[i] = s;
    }
}

/* y = L^-T D^-1 y */
static void backward(const double *L, const double *inv_d, double *y)
{
    int i, k;
    for (i = N - 1; i >= 0; --i) {
        double s = y[i] * inv_d[i];
        for (k = i + 1; k < N; ++k)
            s -= L[k * N + i] * y[k];
        y[i] = s;
    }
}

/* C = G K^-1 G^T = Y^T D^-1 Y with Y = L^-1 G^T, for the first ROWS rows of each output */
static void compliances(const state *s, const double *L, const double *inv_d)
{
    double y[ROWS][N];
    int o, i, j, k;
    for (o = 0; o < NOUT; ++o) {
        for (i = 0; i < ROWS; ++i)
            forward(L, s->GT + (3 * o + i) * N, y[i]);
        for (i = 0; i < ROWS; ++i)
            for (j = 0; j <= i; ++j) {
                double c = 0.0;
                for (k = 0; k < N; ++k)
                    c += y[i][k] * y[j][k] * inv_d[k];
                compliance[o][i][j] = compliance[o][j][i] = c;
            }
    }
}

int peer_setup(void)
{
    return 0;
}

int peer_solve(int input, int warm)
{
    const double *u = peer_inputs[input];
    state *a = &states[0], *b = &states[1], *t;
    double L[N * N], inv_d[N], dq[N];
    int i, h;
    iterations = calls = stable = 0;
    if (warm)
        memcpy(a->q, q_kept, sizeof a->q);
    else
        memset(a->q, 0, sizeof a->q);
    evaluate(a, u);
    while (relative_residual(a) > TOL) {
        double mu = 0.0, slope = 0.0, step = 1.0;
        if (iterations == MAX_ITERATIONS)
            return 1;
        while (!factor(a->K, mu, L, inv_d)) {
            mu = mu > 0.0 ? 2.0 * mu : 1e-3;
            if (mu > 1e12)
                return 1;
        }
        forward(L, a->r, dq);
        backward(L, inv_d, dq);
        for (i = 0; i < N; ++i) {
            dq[i] = -dq[i];
            slope += a->r[i] * dq[i];
        }
        for (h = 0;; ++h) {
            for (i = 0; i < N; ++i)
                b->q[i] = a->q[i] + step * dq[i];
            evaluate(b, u);
            if (b->Pi <= a->Pi + ARMIJO * step * slope || max_abs(b->r) < max_abs(a->r))
                break;
            if (h == MAX_HALVINGS)
                return 1;
            step *= 0.5;
        }
        t = a;
        a = b;
        b = t;
        ++iterations;
        if (step * max_abs(dq) < STEP_TOL)
            break;
    }
    answer_state = a;
    memcpy(q_kept, a->q, sizeof q_kept);
    stable = factor(a->K, 0.0, L, inv_d);
    if (!stable)
        return 2;
    compliances(a, L, inv_d);
    return 0;
}

void peer_read(peer_answer *out)
{
    int o, i, j;
    out->stable = stable;
    out->iterations = iterations;
    out->calls = calls;
    out->noutputs = NOUT;
    out->rows = ROWS;
    for (o = 0; o < NOUT; ++o) {
        for (i = 0; i < 3; ++i)
            out->pose[o][i] = answer_state->pose[3 * o + i];
        for (i = 0; i < ROWS; ++i)
            for (j = 0; j < ROWS; ++j)
                out->compliance[o][i][j] = compliance[o][i][j];
    }
}

double peer_probe(void)
{
    return answer_state->pose[0] + compliance[NOUT - 1][ROWS - 1][ROWS - 1];
}
