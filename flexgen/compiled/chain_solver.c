/* The chain solver: equilibrium and compliance of a scene in one call.
 *
 * This file is the single implementation of the chain solver. It holds the whole algorithm: the
 * full load in one Newton solve from the unloaded state when every check of the direct attempt
 * passes (direct_solve), else the load continuation (continuation), or a warm start from a
 * given q0; then polishing, the compliance of the output points and the stiffness (finish), and
 * what the validity of the answer depends on: the margin to a critical load, each flexure's
 * largest bend, the kernel evaluating it, each output's compliance ellipse (describe_answer,
 * fg_ellipse). The continuation handles a loss of stability: a step from a stable onto an
 * unstable state is a bifurcation (such as Euler buckling: located by regula falsi on the
 * smallest eigenvalue, then the stable side taken by descent, cross_bifurcation) or else
 * overshoots a limit point (a shorter step); where the path ends the solve descends to the
 * equilibrium it snaps to (a snap-through). Each such critical load factor is reported in
 * fg_answer.critical with its kind, and so is every flexure whose first kernel (polynomial or
 * local: "auto" and "local" models) left its range and whose Gauss kernel took over
 * (fg_answer.switched).
 *
 * Every solve ends with an answer (FG_SOLVED) or with the reason there is none
 * (FG_NO_EQUILIBRIUM): fg_answer.failure (FG_FAIL_*: the unloaded state cannot be evaluated, the
 * step budget ran out, no stable state past a bifurcation, none beyond a limit point) at
 * failure_load_factor, the last error met on the way (last_error: FG_ERR_* with the load factor,
 * relative residual, iteration limit, flexure or tendon segment it concerns) and the last model
 * error (model_error*). A warm start that is not accepted goes on from the unloaded state, an
 * unstable unloaded state or max_steps < 1 goes to the continuation (which then proceeds or
 * fails with its own reason), critical events beyond the caller's array are counted, not
 * stored. FG_MODEL_ERROR: a malformed fg_problem only (well_formed).
 *
 * Python calls it through cffi (flexgen/compiled/_build_core.py compiles it into flexgen._core):
 * flexgen/problem.py fills the fg_problem of a scene by field name (flexures in body order;
 * points: the load points, then the tendon route points, then the outputs, each point once),
 * flexgen/solver.py calls fg_solve and builds the Result from fg_answer (the buckling and
 * snap-through warnings from the critical events: BUCKLING_SIDES words the FG_BUCKLING_* kinds),
 * and flexgen/reasons.py words the FG_FAIL_* and FG_ERR_* codes. A C program gets the structs of a
 * scene from flexgen generate --scene (examples/controller/two_link_finger/two_link_finger.c).
 * flexgen/chain.py has kinematics of its own: the frame poses of an answer (its stresses, its
 * drawing) and a reference Jacobian and Hessian for tests; the solver's are this file's.
 *
 * Tests: tests/test_solver_core.py checks the answers against independent references (the exact
 * elastica, closed forms such as Euler's critical loads, finite differences of the residual and
 * of repeated solves), tests/test_answer_fields.py the answer's fields, tests/test_settings.py
 * that flexgen/settings.py's SolverSettings matches fg_settings.
 *
 * Every tuning constant comes from fg_problem.settings (fg_settings: flexgen/settings.py).
 *
 * Cost: a chain evaluation (kinematics, potential, residual, stiffness: evaluate) is O(n^2) in
 * the n coordinates (the Hessian accumulation's blockwise rank-one terms, each frame's rotation
 * computed once); the factorizations are O(n^3) (LAPACK's from lapack_min_size coordinates on),
 * in the coordinates that remain after each flexure's non-angle ones are eliminated
 * (plan_elimination, from elimination_min_size coordinates on).
 *
 * Flexure models: the generated smooth curvature kernels (scm{N}, scm{N}_gauss{G}: function
 * pointers, so this file needs no header of theirs), the n-element chain ("fem", the
 * discretisation documented in flexgen/models/fem.py) and the pseudo-rigid body ("prb").
 * Every elastic energy is quadratic with a diagonal Hessian (``stiffness``).
 *
 * Linear algebra: built-in Cholesky, LU and (cyclic Jacobi) symmetric eigen-decomposition, or
 * LAPACK's dpotrf, dgetrf/dgetrs and dsyev by function pointer (fg_lapack) from
 * settings.lapack_min_size coordinates on (the triangular solves with a Cholesky factor are
 * always the built-in ones; fg_lapack.potrs is not called). The symmetric S and K hold their
 * upper triangles only (see the Hessian accumulation).
 *
 * C99, no heap, no globals: the caller provides the workspace (fg_work_size doubles and
 * fg_iwork_size ints). Compiled with gcc -std=c99 -Wall -Wextra -Werror -pedantic.
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "chain_solver.h"

/* the largest finite value, the machine epsilon and a floor for divisors, of fg_real */
#ifdef FG_SINGLE
#define FG_REAL_MAX FLT_MAX
#define FG_EPS FLT_EPSILON
#define FG_TINY 1e-30f
#else
#define FG_REAL_MAX DBL_MAX
#define FG_EPS DBL_EPSILON
#define FG_TINY 1e-300
#endif

/* ---- sizes ------------------------------------------------------------------------------ */

/* The problem's sizes, read through these macros. The library reads each from its fg_problem
 * (and fg_ws.n, its ndof). A scene controller (flexgen generate --scene) knows its scene's sizes
 * and defines FG_FIXED_SIZES and FG_FIXED_NDOF .. FG_FIXED_NOUTPUTS before this file (and
 * FG_FIXED_FLEX_NDOF where every flexure has as many coordinates), so that the compiler unrolls
 * and folds the loops over coordinates, flexures, points, loads and tendons: 19 % fewer
 * instructions per solve for one 3-mode flexure (docs/controller.md, Speed). problem_well_formed
 * reads the fields themselves and refuses a problem whose sizes are not the fixed ones. A fixed
 * size still names its argument (cast to void): the functions that read a size only keep their
 * parameters and locals used. */
#ifdef FG_FIXED_SIZES
#define FG_N(w) ((void)(w), FG_FIXED_NDOF)
#define FG_NDOF(p) ((void)(p), FG_FIXED_NDOF)
#define FG_NFLEX(p) ((void)(p), FG_FIXED_NFLEX)
#define FG_NPOINTS(p) ((void)(p), FG_FIXED_NPOINTS)
#define FG_NLOADS(p) ((void)(p), FG_FIXED_NLOADS)
#define FG_NTENDONS(p) ((void)(p), FG_FIXED_NTENDONS)
#define FG_NOUTPUTS(p) ((void)(p), FG_FIXED_NOUTPUTS)
#else
#define FG_N(w) ((w)->n)
#define FG_NDOF(p) ((p)->ndof)
#define FG_NFLEX(p) ((p)->nflex)
#define FG_NPOINTS(p) ((p)->npoints)
#define FG_NLOADS(p) ((p)->nloads)
#define FG_NTENDONS(p) ((p)->ntendons)
#define FG_NOUTPUTS(p) ((p)->noutputs)
#endif
#ifdef FG_FIXED_FLEX_NDOF
#define FG_FLEX_NDOF(f) ((void)(f), FG_FIXED_FLEX_NDOF)
#else
#define FG_FLEX_NDOF(f) ((f)->ndof)
#endif

/* ---- workspace ------------------------------------------------------------------------- */

#define FG_NSTATES 6        /* states held at once (the bifurcation crossing needs five) */
#define FG_FDATA 12         /* doubles of per-flexure kinematics data (fg_ws.fdata) */
/* The built-in Jacobi eigen-solver's own accuracy (rotations stop below this fraction of |A|,
 * so its eigenvalues are LAPACK's to a few ulps) and a bound on its sweeps (it converges
 * quadratically, in about ten): properties of the numerical method, not tuning of the solve
 * (fg_settings holds those). */
#define FG_PI 3.14159265358979323846
#define FG_JACOBI_SMALL 1e-18
#define FG_JACOBI_SWEEPS 100
#define FG_LWORK(n) (34 * (n) + 1)   /* dsyev's work: enough for its blocked reduction */
/* a tendon segment between two bodies at most this fraction of the longest flexure long where
 * the load path ends has been pulled shut: its ends meet and its pull turns about there, which
 * ends the path (name_short_tendon); the exact solver's models.exact.SHORT_TENDON */
#define FG_SHORT_TENDON 1e-3
/* fg_estimate's Newton is seen to converge when a step is at most this fraction of the one
 * before (quadratic convergence from within its basin): the compliance taken there is then off
 * by about this fraction of the distance to the richer equilibrium, which the margins of
 * flexgen/estimate.py cover (measured: one state, T q itself, is not enough) */
#define FG_ESTIMATE_CONTRACTION 0.1
#define FG_BEND_REFINE 4      /* refinements of the largest bend sample (bend_refined) */

typedef struct {
    fg_real *q, *gU, *QL, *QT, *S;   /* load-independent parts (S: load Hessian at lam = 1) */
    fg_real *r, *K, *Q;              /* at the state's load factor */
    fg_real *out;                    /* per output point: pose (3), J (3 x n), at q */
    fg_real U, W, V, gmax, rmax, Pi, scale, rel, lam;
    int sfinite, kfinite;           /* every entry of S, K is finite */
} fg_state;

typedef struct {
    const fg_problem *p;
    const fg_settings *set;
    int n;
    size_t tstride;         /* doubles per flexure tip block (tip_block) */
    /* kinematics at the last evaluated q */
    fg_real *fpose, *fJ;     /* per flexure tip frame: pose (3), J (3 x n) */
    fg_real *fdata;          /* per flexure (FG_FDATA): moving_parent, awx, awy, c, s (root frame
                             * rotation), wx, wy, moving, ct, st (tip frame rotation), lo, hi
                             * (the tip frame's J is zero outside the coordinates [lo, hi): those
                             * of the flexure and its ancestors lie in it; bind sets [0, n): its
                             * columns are not known to be zero before the first kinematics) */
    fg_real *dk;             /* per flexure: the rank-one coefficients summed over its subtree */
    fg_real *kq;             /* the q of the last kinematics (kin_ok: they succeeded) */
    int kin_ok;
    int *kin_kernel;        /* per flexure: the kernel the last kinematics evaluated
                             * (FG_KERNEL_LOCAL or _POLY: q was in that kernel's set; _GAUSS;
                             * FG_KERNEL_NONE: not a kernel model) */
    int *rotated;           /* per flexure: 1 if its tip frame's rotation is read (a child, or a
                             * point off its origin: set by fg_solve); else not computed */
    int poly_in_range;      /* 1: the next kinematics' q is known to be within the set of every
                             * flexure's first kernels (in_kernel_range said so): a flexure whose
                             * local kernel is not certified there takes its polynomial kernel
                             * without asking its range */
    int la_factors_cur;     /* 1: newton returned with la holding its state's K's Cholesky
                             * factor (its last step linearized: K is that of the step's start) */
    int evaluations;        /* kinematics evaluated in this solve */
    /* the last error and the last model error (fg_answer.last_error*, model_error*) */
    int err, err_flex, err_route, err_iterations;
    fg_real err_lam, err_rel;
    int merr, merr_flex, merr_route;
    int fail_flex, fail_route;      /* where the last failed evaluation failed */
    fg_real *tpose, *tJ, *tH, *RJ;   /* per flexure tip kinematics (root frame), R dv rows */
    fg_real *ppose, *pJ;     /* per point: pose (3), J (3 x n) */
    fg_real *acc;            /* per flexure: Hessian accumulators (4) */
    fg_real *scratch;        /* fem tip: 4 (kmax + 1) */
    fg_real *reach;          /* n */
    fg_real *la, *lb, *lc;   /* n x n linear algebra scratch, n-vectors */
    /* the factorization's elimination order (plan_elimination): nelim = 0, the natural order;
     * else perm (n) lists the coordinates in the factor's order, the eliminated ones first in
     * nblocks blocks (blocks: 3 ints each: first row, rows, kept columns reached), and etmp is
     * an n-vector in that order */
    int nelim, nblocks;
    int *perm, *blocks;
    fg_real *etmp;
    fg_real *vec1, *vec2, *vec3, *vec4, *t0, *t1;   /* n-vectors */
    fg_real *vmin, *cvec, *qplus, *qminus;          /* n-vectors (stability, descent) */
    fg_real *mr;             /* n-vector: a tendon segment's rank-one vector over its length */
    fg_real *hf;             /* per load: |(fx, fy)| (set by fg_solve: the loads are fixed) */
    fg_real hist[FG_MAX_LAG + 1];    /* Newton's last stagnation_lag + 1 relative residuals */
    fg_real *ew, *eV, *ework;    /* eigenvalues (n), eigenvectors (n x n, one a row), scratch */
    int *piv;
    int *switched;          /* per flexure: an "auto" flexure used its Gauss kernel since the
                             * flags were last cleared (fg_answer.switched) */
    int *saved_switched;    /* per flexure: the flags before a trial (save_trial) */
    fg_state st[FG_NSTATES];
} fg_ws;

static int kmax(const fg_problem *p)
{
    int i, m = 0;
    for (i = 0; i < FG_NFLEX(p); ++i)
        if (p->flex[i].ndof > m)
            m = p->flex[i].ndof;
    return m;
}

/* the doubles of one flexure's tip block: J (3 k), H (3 k k), RJ (2 k) for k = kmax */
static size_t tip_stride(const fg_problem *p)
{
    size_t k = (size_t)kmax(p);
    return 3 * k + 3 * k * k + 2 * k;
}

static size_t tip_size(const fg_problem *p)
{
    return (size_t)FG_NFLEX(p) * (3 + tip_stride(p));
}

FG_API size_t fg_work_size(const fg_problem *p)
{
    size_t n = (size_t)FG_NDOF(p), F = (size_t)FG_NFLEX(p), P = (size_t)FG_NPOINTS(p);
    size_t state = 6 * n + 2 * n * n + (size_t)FG_NOUTPUTS(p) * (3 + 3 * n);
    return F * (3 + 3 * n) + FG_FDATA * F + tip_size(p) + P * (3 + 3 * n) + 4 * F + F + n
        + 4 * ((size_t)kmax(p) + 1) + n + 3 * n * n + 11 * n + (size_t)FG_NLOADS(p)
        + n + n * n + 2 * n * n + FG_LWORK(n) + FG_NSTATES * state + n + 3 * n + 16;
}

FG_API size_t fg_iwork_size(const fg_problem *p)
{
    /* pivots, kernel-switch flags (2), the kernels of the last kinematics, rotated frames,
     * the elimination order (perm, blocks, a mark per flexure) */
    return 2 * (size_t)FG_NDOF(p) + 1 + 8 * (size_t)FG_NFLEX(p);
}

static void plan_elimination(fg_ws *w);

static void bind(fg_ws *w, const fg_problem *p, fg_real *work, int *iwork)
{
    size_t n = (size_t)FG_NDOF(p), F = (size_t)FG_NFLEX(p), P = (size_t)FG_NPOINTS(p);
    fg_real *x = work;
    int i;
    w->p = p;
    w->set = &p->settings;
    w->tstride = tip_stride(p);
    w->n = FG_NDOF(p);
    w->kin_ok = 0;
    w->poly_in_range = 0;
    w->la_factors_cur = 0;
    w->evaluations = 0;
    w->err = FG_ERR_NONE;
    w->err_flex = w->err_route = -1;
    w->err_iterations = 0;
    w->err_lam = w->err_rel = 0.0;
    w->merr = FG_ERR_NONE;
    w->merr_flex = w->merr_route = -1;
    w->fail_flex = w->fail_route = -1;
    w->fpose = x; x += 3 * F;
    w->fJ = x; x += 3 * n * F;
    w->fdata = x; x += FG_FDATA * F;
    w->dk = x; x += F;
    w->kq = x; x += n;
    w->tpose = x; x += 3 * F;
    w->tJ = x;
    w->tH = NULL;
    w->RJ = NULL;
    x += tip_size(p) - 3 * F;   /* tJ, tH, RJ blocks laid out per flexure (see tip_block) */
    w->ppose = x; x += 3 * P;
    w->pJ = x; x += 3 * n * P;
    w->acc = x; x += 4 * F;
    w->scratch = x; x += 4 * ((size_t)kmax(p) + 1);
    w->reach = x; x += n;
    w->la = x; x += n * n;
    w->lb = x; x += n * n;
    w->lc = x; x += n * n + 3 * n;   /* also 3 columns of n (compliance, estimate), n < 3 too */
    w->vec1 = x; x += n;
    w->vec2 = x; x += n;
    w->vec3 = x; x += n;
    w->vec4 = x; x += n;
    w->t0 = x; x += n;
    w->t1 = x; x += n;
    w->vmin = x; x += n;
    w->cvec = x; x += n;
    w->qplus = x; x += n;
    w->qminus = x; x += n;
    w->mr = x; x += n;
    w->hf = x; x += (size_t)FG_NLOADS(p);
    w->ew = x; x += n;
    w->eV = x; x += n * n;
    w->ework = x; x += 2 * n * n + FG_LWORK(n);
    w->etmp = x; x += n;
    for (i = 0; i < FG_NSTATES; ++i) {
        fg_state *s = &w->st[i];
        s->q = x; x += n;
        s->gU = x; x += n;
        s->QL = x; x += n;
        s->QT = x; x += n;
        s->r = x; x += n;
        s->Q = x; x += n;
        s->S = x; x += n * n;
        s->K = x; x += n * n;
        s->out = x; x += (size_t)FG_NOUTPUTS(p) * (3 + 3 * n);
    }
    w->piv = iwork;
    w->switched = iwork + FG_NDOF(p) + 1;
    w->saved_switched = w->switched + FG_NFLEX(p);
    w->kin_kernel = w->saved_switched + FG_NFLEX(p);
    w->rotated = w->kin_kernel + FG_NFLEX(p);
    w->perm = w->rotated + FG_NFLEX(p);
    w->blocks = w->perm + FG_NDOF(p);
    w->nelim = w->nblocks = 0;
    if (FG_NDOF(p) >= p->settings.elimination_min_size)
        plan_elimination(w);
    for (i = 0; i < FG_NFLEX(p); ++i) {    /* every frame's J: any column may hold garbage */
        w->fdata[FG_FDATA * (size_t)i + 10] = 0.0;
        w->fdata[FG_FDATA * (size_t)i + 11] = (fg_real)FG_NDOF(p);
    }
}

/* The order in which the stiffness K is factorized (fg_ws.perm).
 *
 * A kernel flexure's tip angle is its first coordinate alone (the Legendre modes above the
 * first integrate to zero along the flexure), so its other coordinates move its own tip position
 * and nothing else. In K (hessian_sum) they couple with each other and with the angle-like
 * coordinates of the flexure and its ancestors, and with nothing else, unless a tendon routes
 * through a frame at or below the flexure (a tendon's length couples every coordinate under its
 * route points). Those coordinates are eliminated first, flexure by flexure, and the rest are
 * kept, in flexure order: the Cholesky factor then has no fill between the eliminated blocks,
 * and a block's rows reach only its own columns and the kept columns of the flexures up to its
 * own (parents are listed before children). On the 32-flexure scm3 chain of the bench (64 of
 * 96 coordinates eliminated) a factorization costs a few times less than the dense one. */
static void plan_elimination(fg_ws *w)
{
    const fg_problem *p = w->p;
    int F = FG_NFLEX(p), i, r, a, ne = 0, nk = 0;
    int *mark = w->blocks + 3 * F;   /* per flexure: 1 eliminable, 0 kept, 2 under a tendon */
    for (i = 0; i < F; ++i) {
        const fg_flexure *f = &p->flex[i];
        mark[i] = f->kind == FG_MODEL_KERNEL && FG_FLEX_NDOF(f) > 1;
    }
    for (r = 0; r < FG_NTENDONS(p); ++r) {
        int e, end = p->route_start[r] + p->route_len[r];
        for (e = p->route_start[r]; e < end; ++e) {
            int fr = p->points[p->route[e]].frame;
            while (fr >= 0 && mark[fr] != 2) {   /* up to a frame already marked */
                mark[fr] = 2;
                fr = p->flex[fr].parent;
            }
        }
    }
    for (i = 0; i < F; ++i)
        if (mark[i] == 1)
            ne += p->flex[i].ndof - 1;
    if (ne == 0)
        return;
    w->nelim = ne;
    w->nblocks = 0;
    ne = 0;
    for (i = 0; i < F; ++i) {
        const fg_flexure *f = &p->flex[i];
        int first = mark[i] == 1 ? 1 : 0;   /* the kept coordinates: the angle, or all */
        for (a = 0; a < (first ? 1 : FG_FLEX_NDOF(f)); ++a)
            w->perm[w->nelim + nk++] = f->offset + a;
        if (first) {
            int *blk = w->blocks + 3 * w->nblocks++;
            blk[0] = ne;
            blk[1] = FG_FLEX_NDOF(f) - 1;
            blk[2] = nk;
            for (a = 1; a < FG_FLEX_NDOF(f); ++a)
                w->perm[ne++] = f->offset + a;
        }
    }
}

/* the tip block of flexure i: J (3 k), H (3 k k), RJ (2 k), after the F tip poses */
static fg_real *tip_block(const fg_ws *w, int i)
{
    return w->tJ + (size_t)i * w->tstride;
}

/* ---- flexure models ------------------------------------------------------------------------ */

/* pose (3), J (3 x k), H (3 x k x k) of the tip in the root frame, physical units; 0 if the
 * model cannot be evaluated at q (past the range of its only kernels). A kernel flexure's kernels
 * are tried in order: the local kernel where it certifies its bound at q, the polynomial kernel
 * within its range, the Gauss kernel (*switched = 1 if it has either of the others). in_range:
 * 1 if q is known to be within the set of the first two (in_kernel_range): the polynomial
 * kernel's range is then not asked, else -1; *used: the kernel evaluated (FG_KERNEL_LOCAL,
 * _POLY, _GAUSS; FG_KERNEL_NONE for the other models) */
static int flexure_tip(const fg_flexure *f, const fg_real *q, fg_real *pose, fg_real *J, fg_real *H,
                       fg_real *scratch, int *switched, int in_range, int *used, int *computed)
{
    int k = FG_FLEX_NDOF(f), i, j;
    *used = FG_KERNEL_NONE;
    if (f->kind == FG_MODEL_KERNEL) {
        fg_kernel kernel;
        fg_real L = f->length;
        int zero = f->tip0 != NULL;
        for (i = 0; i < k && zero; ++i)
            zero = q[i] == 0.0;
        if (zero) {           /* the unloaded flexure: the kernel's constant value at q = 0 */
            memcpy(pose, f->tip0, sizeof(fg_real) * 3);
            memcpy(J, f->tip0 + 3, sizeof(fg_real) * 3 * (size_t)k);
            memcpy(H, f->tip0 + 3 + 3 * k, sizeof(fg_real) * 3 * (size_t)k * (size_t)k);
            /* q = 0 is within every kernel's set */
            *used = f->local != NULL  ? FG_KERNEL_LOCAL
                    : f->poly != NULL ? FG_KERNEL_POLY
                                      : FG_KERNEL_GAUSS;
        } else {
            if (f->local != NULL && f->local_in_range(q)) {
                kernel = f->local;
                *used = FG_KERNEL_LOCAL;
            } else if (f->poly != NULL && (in_range > 0 || f->in_range(q))) {
                kernel = f->poly;
                *used = FG_KERNEL_POLY;
            } else if (f->gauss != NULL) {
                kernel = f->gauss;
                *used = FG_KERNEL_GAUSS;
                if (f->poly != NULL || f->local != NULL)
                    *switched = 1;
            } else
                return 0;       /* past the range of its only kernels */
            kernel(q, pose, J, H);
            *computed = 1;
        }
        pose[0] *= L;
        pose[1] *= L;
        for (i = 0; i < 2 * k; ++i)
            J[i] *= L;
        for (i = 0; i < 2 * k * k; ++i)
            H[i] *= L;
        return 1;
    }
    *computed = 1;
    if (f->kind == FG_MODEL_FEM) {
        /* segments h/2, h, ..., h, h/2; phi_k = q_0 + ... + q_{k-1} */
        fg_real h = f->length / k;
        fg_real *lc = scratch, *ls = scratch + (k + 1), *tc = scratch + 2 * (k + 1),
               *ts = scratch + 3 * (k + 1);
        fg_real phi = 0.0, sc = 0.0, ss = 0.0;
        for (i = 0; i <= k; ++i) {
            fg_real seg = (i == 0 || i == k) ? 0.5 * h : h;
            if (i > 0)
                phi += q[i - 1];
            lc[i] = seg * cos(phi);
            ls[i] = seg * sin(phi);
            sc += lc[i];
            ss += ls[i];
        }
        /* tail sums: tc[i] = sum_{m > i} lc[m] for joint i */
        tc[k] = 0.0;
        ts[k] = 0.0;
        for (i = k - 1; i >= 0; --i) {
            tc[i] = tc[i + 1] + lc[i + 1];
            ts[i] = ts[i + 1] + ls[i + 1];
        }
        pose[0] = sc;
        pose[1] = ss;
        pose[2] = phi;
        for (i = 0; i < k; ++i) {
            J[i] = -ts[i];
            J[k + i] = tc[i];
            J[2 * k + i] = 1.0;
            for (j = 0; j < k; ++j) {
                int m = i > j ? i : j;
                H[i * k + j] = -tc[m];
                H[k * k + i * k + j] = -ts[m];
                H[2 * k * k + i * k + j] = 0.0;
            }
        }
        return 1;
    }
    {   /* FG_MODEL_PRB: rigid (1 - gamma) L, pin, rigid gamma L */
        fg_real a = q[0], r = f->gamma * f->length, c = cos(a), s = sin(a);
        pose[0] = (1.0 - f->gamma) * f->length + r * c;
        pose[1] = r * s;
        pose[2] = a;
        J[0] = -r * s;
        J[1] = r * c;
        J[2] = 1.0;
        H[0] = -r * c;
        H[1] = -r * s;
        H[2] = 0.0;
        return 1;
    }
}

/* ---- kinematics: every frame's and point's pose and Jacobian ---------------------------- */

/* the columns [from, to) of the 3 rows of a frame's J (n columns each) set to zero */
static void zero_columns(fg_real *J, int n, int from, int to)
{
    int a;
    if (from < to)
        for (a = 0; a < 3; ++a)
            memset(J + (size_t)a * (size_t)n + from, 0, sizeof(fg_real) * (size_t)(to - from));
}

static int kinematics(fg_ws *w, const fg_real *q)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i, a, j, computed = 0;
    w->kin_ok = 0;
    for (i = 0; i < FG_NFLEX(p); ++i) {
        const fg_flexure *f = &p->flex[i];
        int k = FG_FLEX_NDOF(f), off = f->offset;
        fg_real *pose = w->fpose + 3 * i, *J = w->fJ + (size_t)3 * n * i;
        fg_real *d = w->fdata + FG_FDATA * i;
        fg_real *tp = w->tpose + 3 * i, *blk = tip_block(w, i);
        fg_real *tJ = blk, *tH = blk + 3 * k, *RJ = blk + 3 * k + 3 * k * k;
        fg_real pp[3] = {0.0, 0.0, 0.0};
        const fg_real *PJ = NULL;
        int moving = 0, tmoving = 0, lo, hi;
        fg_real th, c = 1.0, s = 0.0, awx, awy, rp[3], wx, wy;
        if (f->parent >= 0) {
            const fg_real *pd = w->fdata + FG_FDATA * f->parent;
            memcpy(pp, w->fpose + 3 * f->parent, sizeof pp);
            PJ = w->fJ + (size_t)3 * n * f->parent;
            moving = pd[7] != 0.0;
            c = pd[8];            /* the parent frame's rotation, computed once */
            s = pd[9];
        }
        th = pp[2];
        awx = c * f->at[0] - s * f->at[1];
        awy = s * f->at[0] + c * f->at[1];
        rp[0] = pp[0] + awx;
        rp[1] = pp[1] + awy;
        rp[2] = th + f->at[2];
        if (!flexure_tip(f, q + off, tp, tJ, tH, w->scratch, &w->switched[i],
                         w->poly_in_range ? 1 : -1, &w->kin_kernel[i], &computed)) {
            w->evaluations += computed;
            w->fail_flex = i;
            w->fail_route = -1;
            return 0;
        }
        if (f->at[2] != 0.0) {    /* the root frame is rotated against the parent frame */
            th = rp[2];
            c = cos(th);
            s = sin(th);
        }
        wx = c * tp[0] - s * tp[1];
        wy = s * tp[0] + c * tp[1];
        pose[0] = rp[0] + wx;
        pose[1] = rp[1] + wy;
        pose[2] = rp[2] + tp[2];
        /* J = the parent's J moved by the offset (aw) and by the tip (w), in one pass. J is
         * zero outside [lo, hi) (d[10], d[11]): the parent's range [plo, phi) and this
         * flexure's coordinates. Only that range is written, and what the last kinematics wrote
         * outside it is zeroed: rows are not cleared whole (at 96 coordinates, clearing every
         * frame's rows was 4 % of a solve) */
        lo = off;
        hi = off + k;
        {
            int plo = hi, phi = hi, olo = (int)d[10], ohi = (int)d[11];
            if (PJ != NULL) {
                const fg_real *pd = w->fdata + FG_FDATA * f->parent;
                plo = (int)pd[10];
                phi = (int)pd[11];
                lo = plo < lo ? plo : lo;
                hi = phi > hi ? phi : hi;
            }
            zero_columns(J, n, olo, ohi < lo ? ohi : lo);   /* stale, left of the range */
            zero_columns(J, n, olo > hi ? olo : hi, ohi);   /* stale, right of it */
            zero_columns(J, n, lo, plo);                    /* the range less the parent's */
            zero_columns(J, n, phi, hi);
            if (PJ != NULL && !moving)
                for (a = 0; a < 3; ++a)
                    memcpy(J + (size_t)a * n + plo, PJ + (size_t)a * n + plo,
                           sizeof(fg_real) * (size_t)(phi - plo));
            else if (PJ != NULL)
                for (j = plo; j < phi; ++j) {
                    fg_real jt = PJ[2 * n + j];
                    J[j] = (PJ[j] - awy * jt) - wy * jt;
                    J[n + j] = (PJ[n + j] + awx * jt) + wx * jt;
                    J[2 * n + j] = jt;
                }
        }
        for (a = 0; a < k; ++a) {
            RJ[a] = c * tJ[a] - s * tJ[k + a];
            RJ[k + a] = s * tJ[a] + c * tJ[k + a];
            J[off + a] += RJ[a];
            J[n + off + a] += RJ[k + a];
            J[2 * n + off + a] += tJ[2 * k + a];
            if (tJ[2 * k + a] != 0.0)
                tmoving = 1;
        }
        d[0] = moving;
        d[1] = awx;
        d[2] = awy;
        d[3] = c;
        d[4] = s;
        d[5] = wx;
        d[6] = wy;
        d[7] = moving || tmoving;
        if (w->rotated[i]) {
            d[8] = cos(pose[2]);  /* the tip frame's rotation (its children, points) */
            d[9] = sin(pose[2]);
        } else {                  /* read by nothing (points at the origin: below) */
            d[8] = 1.0;
            d[9] = 0.0;
        }
        d[10] = lo;
        d[11] = hi;
    }
    for (i = 0; i < FG_NPOINTS(p); ++i) {
        const fg_point *pt = &p->points[i];
        fg_real *pose = w->ppose + 3 * i, *J = w->pJ + (size_t)3 * n * i;
        if (pt->frame < 0) {
            pose[0] = pt->x;
            pose[1] = pt->y;
            pose[2] = 0.0;
            memset(J, 0, sizeof(fg_real) * 3 * (size_t)n);
            continue;
        }
        if (pt->x == 0.0 && pt->y == 0.0) {    /* the frame's origin: its pose and J */
            memcpy(pose, w->fpose + 3 * pt->frame, sizeof(fg_real) * 3);
            memcpy(J, w->fJ + (size_t)3 * n * pt->frame, sizeof(fg_real) * 3 * (size_t)n);
            continue;
        }
        {
            const fg_real *fp = w->fpose + 3 * pt->frame, *FJ = w->fJ + (size_t)3 * n * pt->frame;
            const fg_real *fd = w->fdata + FG_FDATA * pt->frame;
            fg_real c = fd[8], s = fd[9];
            fg_real wx = c * pt->x - s * pt->y, wy = s * pt->x + c * pt->y;
            pose[0] = fp[0] + wx;
            pose[1] = fp[1] + wy;
            pose[2] = fp[2];
            memcpy(J, FJ, sizeof(fg_real) * 3 * (size_t)n);
            if (fd[7] != 0.0)
                for (j = 0; j < n; ++j) {
                    J[j] -= wy * FJ[2 * n + j];
                    J[n + j] += wx * FJ[2 * n + j];
                }
        }
    }
    if (q != w->kq)
        memcpy(w->kq, q, sizeof(fg_real) * (size_t)n);
    w->evaluations += computed;
    w->kin_ok = 1;
    return 1;
}

/* a point's coefficients c_p into its frame's accumulators (w->acc) of G += sum_p c_p . H_p */
static void add_coefficient(fg_ws *w, int point, fg_real c0, fg_real c1, fg_real c2)
{
    const fg_point *pt = &w->p->points[point];
    fg_real *a;
    if (pt->frame < 0 || (c0 == 0.0 && c1 == 0.0 && c2 == 0.0))
        return;
    a = w->acc + 4 * pt->frame;
    a[0] += c0;
    a[1] += c1;
    a[2] += c2;
    if (pt->x != 0.0 || pt->y != 0.0) {
        const fg_real *fd = w->fdata + FG_FDATA * pt->frame;
        fg_real c = fd[8], s = fd[9];
        fg_real wx = c * pt->x - s * pt->y, wy = s * pt->x + c * pt->y;
        a[2] += c1 * wx - c0 * wy;
        a[3] += c0 * wx + c1 * wy;
    }
}

/* The Hessian term sum_p c_p . H_p of every point p (loads, tendons), accumulated frame
 * by frame from the leaves to the base: each frame's coefficients (force c0, c1, moment c2 and
 * the rank-one coefficient kk of its angle row) act on its own tip Hessian, on the cross terms
 * with its parent's angle, and pass on to the parent frame.
 *
 * The rank-one terms -sum_f kk_f Jth_f Jth_f^T (Jth_f: frame f's angle row) are summed in O(n^2)
 * rather than one n x n update per frame: Jth_f is nonzero exactly on the coordinates of f and
 * its ancestors, where it is their own tip angle derivative a_j (tJ's angle row). So entry (i, j)
 * of the sum is a_i a_j times the sum of kk over the frames that lie below (or at) both the
 * flexure of i and that of j: none unless one of the two flexures, h, is an ancestor of (or is)
 * the other, g, and then the sum dk_g of kk over g's subtree. Each pair (h, g) is one block.
 * The blocks of g with its ancestors are a_j (dk_g a_g) on the ancestors' coordinates j, where
 * a_j is also the parent frame's angle row Jr[j]: they join g's cross terms with that row, one
 * pass over it per flexure.
 *
 * G is symmetric and only its upper triangle (row-major: column >= row; LAPACK's column-major
 * lower triangle) is built, everywhere in this file: an off-diagonal pair of equal terms goes to
 * the upper one of its two places. The lower triangle of S and K is never read (sym_copy). */
static void hessian_sum(fg_ws *w, fg_real *G)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i, a, b, j;
    for (i = FG_NFLEX(p) - 1; i >= 0; --i) {
        const fg_flexure *f = &p->flex[i];
        int k = FG_FLEX_NDOF(f), off = f->offset;
        fg_real *acc = w->acc + 4 * i, *d = w->fdata + FG_FDATA * i, *blk = tip_block(w, i);
        fg_real *tJ = blk, *tH = blk + 3 * k, *RJ = blk + 3 * k + 3 * k * k;
        const fg_real *ag = tJ + 2 * k;       /* this flexure's tip angle row */
        fg_real c0 = acc[0], c1 = acc[1], c2 = acc[2], kk = acc[3];
        fg_real c = d[3], s = d[4], e0, e1, dki;
        int forces = c0 != 0.0 || c1 != 0.0 || c2 != 0.0;
        /* dk: kk summed over the subtree (the children, later in the list, added theirs) */
        w->dk[i] += kk;
        dki = w->dk[i];
        if (f->parent >= 0)
            w->dk[f->parent] += dki;
        /* the diagonal block: the tip Hessian and the block (i, i) of the rank-one terms */
        e0 = c * c0 + s * c1;
        e1 = c * c1 - s * c0;
        for (a = 0; a < k; ++a) {
            fg_real *row = G + (size_t)(off + a) * n + off, ra = dki * ag[a];
            for (b = 0; b < k; ++b)
                row[b] += e0 * tH[a * k + b] + e1 * tH[k * k + a * k + b]
                          + c2 * tH[2 * k * k + a * k + b] - ra * ag[b];
        }
        if (f->parent < 0)
            continue;
        if (d[0] != 0.0 && (forces || dki != 0.0)) {
            /* the parent frame moves: the cross terms with its angle row Jr (m: the forces'
             * through the rotated tip, minus the rank-one blocks with the ancestors). Jr is zero
             * outside [lo, hi) (kinematics) and on this flexure's own coordinates; each term
             * with its transpose, in the upper triangle: rows j < off (k entries each), row
             * off + a right of it */
            const fg_real *Jr = w->fJ + (size_t)3 * n * f->parent + 2 * (size_t)n;
            int lo = (int)w->fdata[FG_FDATA * f->parent + 10];
            int hi = (int)w->fdata[FG_FDATA * f->parent + 11];
            int left = hi < off ? hi : off, right = lo > off + k ? lo : off + k;
            fg_real *m = w->scratch;     /* k entries (the fem scratch, free here) */
            for (a = 0; a < k; ++a)
                m[a] = c1 * RJ[a] - c0 * RJ[k + a] - dki * ag[a];
            for (j = lo; j < left; ++j) {
                fg_real *row = G + (size_t)j * n + off, jr = Jr[j];
                for (a = 0; a < k; ++a)
                    row[a] += m[a] * jr;
            }
            for (a = 0; a < k; ++a) {
                fg_real *row = G + (size_t)(off + a) * n;
                for (j = right; j < hi; ++j)
                    row[j] += m[a] * Jr[j];
            }
        }
        if (forces) {             /* the coefficients pass on to the parent frame */
            fg_real wx = d[5], wy = d[6], awx = d[1], awy = d[2];
            fg_real r2 = c2 + c1 * wx - c0 * wy, kr = c0 * wx + c1 * wy;
            fg_real *pa = w->acc + 4 * f->parent;
            pa[0] += c0;
            pa[1] += c1;
            pa[2] += r2 + c1 * awx - c0 * awy;
            pa[3] += kr + c0 * awx + c1 * awy;
        }
    }
}

/* ---- the potential: parts at q, then the state at a load factor -------------------------- */
static int evaluate_parts(fg_ws *w, const fg_real *q, fg_real lam, fg_state *st);

static int finite_all(const fg_real *x, size_t m)
{
    size_t i;
    for (i = 0; i < m; ++i)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

static size_t out_size(const fg_ws *w)
{
    return (size_t)FG_NOUTPUTS(w->p) * (3 + 3 * (size_t)FG_N(w));
}

/* K[j] = lam S[j], j < m; returns 0 if every S[j] is finite, else NaN: S[j] - S[j] is 0 for a
 * finite entry and NaN for an infinite or NaN one. Summed in two lanes from the row's first
 * entry, this loop vectorizes (a comparison per entry kept it scalar: a fifth of a chain
 * evaluation at 96 coordinates). */
static fg_real scaled_row(fg_real *K, const fg_real *S, fg_real lam, int m)
{
    fg_real z0 = 0.0, z1 = 0.0;
    int j;
    for (j = 0; j + 1 < m; j += 2) {
        K[j] = lam * S[j];
        K[j + 1] = lam * S[j + 1];
        z0 += S[j] - S[j];
        z1 += S[j + 1] - S[j + 1];
    }
    if (j < m) {
        K[j] = lam * S[j];
        z0 += S[j] - S[j];
    }
    return z0 + z1;
}

/* The state at load factor lam from its load-independent parts (fresh: S was just built);
 * S: NULL (st's own), or the S to use instead (st's own is then not read) */
static void at_lambda(const fg_ws *w, fg_state *st, const fg_real *S, fg_real lam, int fresh)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i, j;
    fg_real rn = 0.0;
    int bad = 0;
    st->lam = lam;
    for (i = 0; i < n; ++i) {
        st->r[i] = st->gU[i] - lam * st->QL[i] + lam * st->QT[i];
        st->Q[i] = st->QL[i] - st->QT[i];
        if (fabs(st->r[i]) > rn)
            rn = fabs(st->r[i]);
    }
    /* K = stiffness + lam S, upper triangles only. Every entry finite: S's
     * (sfinite, found here once per evaluation: fresh), and then lam S_ij is too for
     * |lam| <= 1 (every load factor of the solve); the diagonal and other lam checked here. */
    if (S == NULL)
        S = st->S;
    if (fresh) {
        fg_real z = 0.0;
        for (i = 0; i < n; ++i) {
            fg_real *Ki = st->K + (size_t)i * (size_t)n;
            z += scaled_row(Ki + i, S + (size_t)i * (size_t)n + i, lam, n - i);
            Ki[i] += p->stiffness[i];
            bad |= !(fabs(Ki[i]) <= FG_REAL_MAX);
        }
        st->sfinite = z == 0.0;
    } else
        for (i = 0; i < n; ++i) {
            const fg_real *Si = S + (size_t)i * (size_t)n;
            fg_real *Ki = st->K + (size_t)i * (size_t)n;
            for (j = i; j < n; ++j)
                Ki[j] = lam * Si[j];
            Ki[i] += p->stiffness[i];
            bad |= !(fabs(Ki[i]) <= FG_REAL_MAX);
        }
    if (!(fabs(lam) <= 1.0))
        for (i = 0; i < n; ++i)
            for (j = i + 1; j < n; ++j)
                bad |= !(fabs(st->K[(size_t)i * (size_t)n + j]) <= FG_REAL_MAX);
    st->kfinite = st->sfinite && !bad;
    st->Pi = st->U - lam * st->W + lam * st->V;
    st->scale = st->gmax > fabs(lam) * st->rmax ? st->gmax : fabs(lam) * st->rmax;
    if (rn == 0.0)
        st->rel = 0.0;
    else
        st->rel = st->scale > 0.0 ? rn / st->scale : INFINITY;
}

/* ---- the last error and the last model error (fg_answer.last_error*, model_error*) ------ */

static void set_error(fg_ws *w, int code, fg_real lam, fg_real rel)
{
    w->err = code;
    w->err_lam = lam;
    w->err_rel = rel;
    w->err_iterations = 0;
    w->err_flex = w->err_route = -1;
}

/* the model error of the last failed evaluation: both the last error and the model error */
static void set_model_error(fg_ws *w)
{
    int code = w->fail_flex >= 0 ? FG_ERR_KERNEL_RANGE : FG_ERR_TENDON;
    set_error(w, code, 0.0, 0.0);
    w->err_flex = w->merr_flex = w->fail_flex;
    w->err_route = w->merr_route = w->fail_route;
    w->merr = code;
}

static void clear_model_error(fg_ws *w)
{
    w->merr = FG_ERR_NONE;
    w->merr_flex = w->merr_route = -1;
}

typedef struct {
    int err, err_flex, err_route, err_iterations, merr, merr_flex, merr_route;
    fg_real err_lam, err_rel;
} fg_errors;

/* A trial that is no part of the answer's path (the direct attempt, the warm start's path
 * samples) leaves the last errors and the kernel-switch flags as they were: save_trial before
 * it, restore_trial after (the flags in fg_ws.saved_switched, one trial at a time). */
static void save_trial(fg_ws *w, fg_errors *e)
{
    memcpy(w->saved_switched, w->switched, sizeof(int) * (size_t)FG_NFLEX(w->p));
    e->err = w->err;
    e->err_flex = w->err_flex;
    e->err_route = w->err_route;
    e->err_iterations = w->err_iterations;
    e->err_lam = w->err_lam;
    e->err_rel = w->err_rel;
    e->merr = w->merr;
    e->merr_flex = w->merr_flex;
    e->merr_route = w->merr_route;
}

static void restore_trial(fg_ws *w, const fg_errors *e)
{
    memcpy(w->switched, w->saved_switched, sizeof(int) * (size_t)FG_NFLEX(w->p));
    w->err = e->err;
    w->err_flex = e->err_flex;
    w->err_route = e->err_route;
    w->err_iterations = e->err_iterations;
    w->err_lam = e->err_lam;
    w->err_rel = e->err_rel;
    w->merr = e->merr;
    w->merr_flex = e->merr_flex;
    w->merr_route = e->merr_route;
}

/* the state's values are finite (else the last error says so: FG_ERR_NONFINITE) */
static int state_finite(fg_ws *w, const fg_state *st)
{
    if (!isfinite(st->Pi) || !finite_all(st->r, (size_t)FG_N(w)) || !st->kfinite) {
        set_error(w, FG_ERR_NONFINITE, st->lam, 0.0);
        return 0;
    }
    return 1;
}

/* the state at (q, lam); 0 if a model cannot be evaluated or a value is not finite (the last
 * error, and for a model, the model error, say which) */
static int evaluate(fg_ws *w, const fg_real *q, fg_real lam, fg_state *st)
{
    if (!evaluate_parts(w, q, lam, st)) {
        set_model_error(w);
        return 0;
    }
    return state_finite(w, st);
}

/* 1 if route entry e's segment joins two points of one rigid body (one frame): its length is
 * constant and its pulls cancel on that body (equal, opposite, on one line), so it acts on
 * nothing, its ends may even coincide; evaluate_parts skips it, name_short_tendon too */
static int one_body_segment(const fg_problem *p, int e)
{
    return p->points[p->route[e]].frame == p->points[p->route[e + 1]].frame;
}

/* the state at (q, lam), its values unchecked; 0 if a model cannot be evaluated (fail_flex) or
 * a tendon segment has zero length (fail_route) */
static int evaluate_parts(fg_ws *w, const fg_real *q, fg_real lam, fg_state *st)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i, j, t, a, b;
    if (st->q != q)
        memcpy(st->q, q, sizeof(fg_real) * (size_t)n);
    if (!kinematics(w, st->q))
        return 0;
    for (i = 0; i < FG_NOUTPUTS(p); ++i) {
        int pt = p->outputs[i];
        fg_real *o = st->out + (size_t)i * (3 + 3 * (size_t)n);
        memcpy(o, w->ppose + 3 * pt, sizeof(fg_real) * 3);
        memcpy(o + 3, w->pJ + (size_t)3 * n * pt, sizeof(fg_real) * 3 * (size_t)n);
    }
    st->U = 0.0;
    st->gmax = 0.0;
    for (i = 0; i < n; ++i) {
        st->U += 0.5 * p->stiffness[i] * st->q[i] * st->q[i];
        st->gU[i] = p->stiffness[i] * st->q[i];
        if (fabs(st->gU[i]) > st->gmax)
            st->gmax = fabs(st->gU[i]);
        st->QL[i] = st->QT[i] = w->reach[i] = 0.0;
    }
    if (n <= 16)                  /* one call (the lower triangle is never read) */
        memset(st->S, 0, sizeof(fg_real) * (size_t)n * (size_t)n);
    else                          /* the upper triangle only */
        for (i = 0; i < n; ++i)
            memset(st->S + (size_t)i * (size_t)n + i, 0, sizeof(fg_real) * (size_t)(n - i));
    memset(w->acc, 0, sizeof(fg_real) * 4 * (size_t)FG_NFLEX(p));
    memset(w->dk, 0, sizeof(fg_real) * (size_t)FG_NFLEX(p));
    st->W = st->V = 0.0;
    for (t = 0; t < FG_NLOADS(p); ++t) {
        int pt = p->load_point[t];
        const fg_real *F = p->load + 3 * t;
        const fg_real *pose = w->ppose + 3 * pt, *J = w->pJ + (size_t)3 * n * pt;
        fg_real hf = w->hf[t], mf = fabs(F[2]);
        st->W += F[0] * pose[0] + F[1] * pose[1] + F[2] * pose[2];
        for (i = 0; i < n; ++i) {
            st->QL[i] += F[0] * J[i] + F[1] * J[n + i] + F[2] * J[2 * n + i];
            w->reach[i] += hf * sqrt(J[i] * J[i] + J[n + i] * J[n + i]) + mf * fabs(J[2 * n + i]);
        }
        add_coefficient(w, pt, -F[0], -F[1], -F[2]);
    }
    for (t = 0; t < FG_NTENDONS(p); ++t) {
        fg_real T = p->tension[t], l = 0.0;
        const int *route = p->route + p->route_start[t];
        fg_real *gl = w->vec1, *m = w->vec2, *mr = w->mr;
        if (T == 0.0)
            continue;
        memset(gl, 0, sizeof(fg_real) * (size_t)n);
        for (j = 0; j + 1 < p->route_len[t]; ++j) {
            int pa = route[j], pb = route[j + 1];
            const fg_real *A = w->ppose + 3 * pa, *B = w->ppose + 3 * pb;
            const fg_real *JA = w->pJ + (size_t)3 * n * pa, *JB = w->pJ + (size_t)3 * n * pb;
            fg_real dx = B[0] - A[0], dy = B[1] - A[1], rho = hypot(dx, dy), ux, uy;
            if (one_body_segment(p, p->route_start[t] + j)) {
                /* nothing on q (review: a route through a flexure's tip and its link's origin,
                 * at one place, was "no equilibrium: zero length", where exact solves it) */
                l += rho;
                continue;
            }
            if (rho == 0.0) {
                w->fail_flex = -1;
                w->fail_route = p->route_start[t] + j;
                return 0;
            }
            ux = dx / rho;
            uy = dy / rho;
            l += rho;
            for (i = 0; i < n; ++i) {
                fg_real Jx = JB[i] - JA[i], Jy = JB[n + i] - JA[n + i];
                gl[i] += ux * Jx + uy * Jy;
                m[i] = ux * Jy - uy * Jx;
                mr[i] = m[i] / rho;
                w->reach[i] += fabs(T) * sqrt(Jx * Jx + Jy * Jy);
            }
            for (a = 0; a < n; ++a)       /* T times the rank-one part of hess l */
                if (m[a] != 0.0) {
                    fg_real tm = T * m[a], *Sa = st->S + (size_t)a * (size_t)n;
                    for (b = a; b < n; ++b)       /* the upper triangle only */
                        Sa[b] += tm * mr[b];
                }
            add_coefficient(w, pb, T * ux, T * uy, 0.0);
            add_coefficient(w, pa, -T * ux, -T * uy, 0.0);
        }
        st->V += T * l;
        for (i = 0; i < n; ++i)
            st->QT[i] += T * gl[i];
    }
    hessian_sum(w, st->S);
    st->rmax = 0.0;
    for (i = 0; i < n; ++i)
        if (w->reach[i] > st->rmax)
            st->rmax = w->reach[i];
    at_lambda(w, st, NULL, lam, 1);
    return 1;
}

/* ---- dense linear algebra (n is small: a few flexures' coordinates) ----------------------- */

/* x . y in four partial sums (a loop the compiler can pair into vector operations, which it
 * may not do for one running sum: that would reorder its additions) */
static fg_real dot(const fg_real *x, const fg_real *y, int n)
{
    fg_real s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int i;
    for (i = 0; i + 3 < n; i += 4) {
        s0 += x[i] * y[i];
        s1 += x[i + 1] * y[i + 1];
        s2 += x[i + 2] * y[i + 2];
        s3 += x[i + 3] * y[i + 3];
    }
    for (; i < n; ++i)
        s0 += x[i] * y[i];
    return (s0 + s1) + (s2 + s3);
}

/* F = the symmetric matrix whose upper triangle is A's (S and K hold only their upper
 * triangles), for the routines that read a full matrix */
static void sym_copy(fg_real *F, const fg_real *A, int n)
{
    int i, j;
    for (i = 0; i < n; ++i) {
        const fg_real *Ai = A + (size_t)i * (size_t)n;
        fg_real *Fi = F + (size_t)i * (size_t)n;
        for (j = i; j < n; ++j) {
            Fi[j] = Ai[j];
            F[(size_t)j * (size_t)n + i] = Ai[j];
        }
    }
}

/* The Cholesky factor U (A = U^T U, row-major upper: dpotrf's column-major lower L = U^T, the
 * same array) of the symmetric A (its upper triangle) in F, by rows: each pivot row scaled,
 * then subtracted from the trailing rows (an axpy along each); 0 if A is not positive definite */
static int factor_builtin(fg_real *F, int n, int lda)
{
    int i, j, k;
    for (k = 0; k < n; ++k) {
        fg_real *Fk = F + (size_t)k * (size_t)lda, d = Fk[k];
        if (!(d > 0.0))
            return 0;
        d = sqrt(d);
        Fk[k] = d;
        d = 1.0 / d;               /* one division per row, the row scaled by multiplications */
        for (j = k + 1; j < n; ++j)
            Fk[j] *= d;
        for (i = k + 1; i < n; ++i) {
            fg_real u = Fk[i], *Fi = F + (size_t)i * (size_t)lda;
            if (u != 0.0)
                for (j = i; j < n; ++j)
                    Fi[j] -= u * Fk[j];
        }
    }
    return 1;
}

/* y = U^-T b, U in F (cholesky's factor, built-in or dpotrf's), by an axpy along each row of U
 * (y may be b). Here and in the back substitution the pivot is applied as a multiplication by
 * its reciprocal: the reciprocal does not depend on y, so the processor computes it ahead, and
 * the chain of dependent steps holds a multiplication where a division's latency stood (on a
 * small stiffness, most of a solve's time). */
static void forward_dense(const fg_real *F, int n, int lda, const fg_real *b, fg_real *y)
{
    int i, j;
    if (y != b)
        memcpy(y, b, sizeof(fg_real) * (size_t)n);
    for (j = 0; j < n; ++j) {
        const fg_real *Fj = F + (size_t)j * (size_t)lda;
        fg_real yj = y[j] * (1.0 / Fj[j]);
        y[j] = yj;
        for (i = j + 1; i < n; ++i)
            y[i] -= Fj[i] * yj;
    }
}

/* x = U^-1 y in place (the back substitution of a solve): a dot product along each row.
 * For one right-hand side these loops cost less than dpotrs's blocked dtrsm. */
static void backward_dense(const fg_real *F, int n, int lda, fg_real *x)
{
    int j;
    for (j = n - 1; j >= 0; --j) {
        const fg_real *Fj = F + (size_t)j * (size_t)lda;
        x[j] = (x[j] - dot(Fj + j + 1, x + j + 1, n - j - 1)) * (1.0 / Fj[j]);
    }
}

/* ---- the factorization in elimination order (plan_elimination) ----------------------------
 * F holds the factor U of P A P^T (P: w->perm), row-major upper as above, written only where
 * it can be non-zero: an eliminated block's rows over the block and its kept columns, the kept
 * rows over the kept columns. Every routine below reads no other entry. */

static fg_real sym_at(const fg_real *A, int n, int i, int j)   /* A's upper triangle */
{
    return i <= j ? A[(size_t)i * (size_t)n + j] : A[(size_t)j * (size_t)n + i];
}

static int cholesky_eliminated(const fg_ws *w, const fg_real *A, fg_real *F)
{
    const fg_problem *p = w->p;
    const int *perm = w->perm;
    int n = FG_N(w), ne = w->nelim, nk = n - ne, b, i, j, k;
    for (b = 0; b < w->nblocks; ++b) {        /* P A P^T where U can be non-zero */
        const int *blk = w->blocks + 3 * b;
        int s = blk[0], e = s + blk[1], kh = ne + blk[2];
        for (i = s; i < e; ++i) {
            fg_real *Fi = F + (size_t)i * (size_t)n;
            for (j = i; j < e; ++j)
                Fi[j] = sym_at(A, n, perm[i], perm[j]);
            for (j = ne; j < kh; ++j)
                Fi[j] = sym_at(A, n, perm[i], perm[j]);
        }
    }
    for (i = ne; i < n; ++i) {
        fg_real *Fi = F + (size_t)i * (size_t)n;
        for (j = i; j < n; ++j)
            Fi[j] = sym_at(A, n, perm[i], perm[j]);
    }
    for (b = 0; b < w->nblocks; ++b) {        /* each block's rows, and their rank-one updates
                                               * of its kept columns' leading block */
        const int *blk = w->blocks + 3 * b;
        int s = blk[0], e = s + blk[1], kh = ne + blk[2];
        for (k = s; k < e; ++k) {
            fg_real *Fk = F + (size_t)k * (size_t)n, d = Fk[k];
            if (!(d > 0.0))
                return 0;
            d = sqrt(d);
            Fk[k] = d;
            d = 1.0 / d;
            for (j = k + 1; j < e; ++j)
                Fk[j] *= d;
            for (j = ne; j < kh; ++j)
                Fk[j] *= d;
            for (i = k + 1; i < e; ++i) {
                fg_real u = Fk[i], *Fi = F + (size_t)i * (size_t)n;
                for (j = i; j < e; ++j)
                    Fi[j] -= u * Fk[j];
                for (j = ne; j < kh; ++j)
                    Fi[j] -= u * Fk[j];
            }
            for (i = ne; i < kh; ++i) {
                fg_real u = Fk[i], *Fi = F + (size_t)i * (size_t)n;
                if (u != 0.0)
                    for (j = i; j < kh; ++j)
                        Fi[j] -= u * Fk[j];
            }
        }
    }
    F += (size_t)ne * (size_t)n + (size_t)ne;   /* the kept block: its Schur complement, dense */
#ifndef FG_SINGLE
    if (p->lapack.potrf != NULL && nk >= p->settings.lapack_min_size) {
        char uplo = 'L';
        int info = 0, lda = n;
        p->lapack.potrf(&uplo, &nk, F, &lda, &info);
        return info == 0;
    }
#endif
    (void)p;
    return factor_builtin(F, nk, n);
}

/* y = U^-T P b (y is not b), in the factor's order */
static void forward_eliminated(const fg_ws *w, const fg_real *F, const fg_real *b, fg_real *y)
{
    int n = FG_N(w), ne = w->nelim, a, b_, i, k;
    for (a = 0; a < n; ++a)
        y[a] = b[w->perm[a]];
    for (b_ = 0; b_ < w->nblocks; ++b_) {
        const int *blk = w->blocks + 3 * b_;
        int s = blk[0], e = s + blk[1], kh = ne + blk[2];
        for (k = s; k < e; ++k) {
            const fg_real *Fk = F + (size_t)k * (size_t)n;
            fg_real yk = y[k] * (1.0 / Fk[k]);
            y[k] = yk;
            for (i = k + 1; i < e; ++i)
                y[i] -= Fk[i] * yk;
            for (i = ne; i < kh; ++i)
                y[i] -= Fk[i] * yk;
        }
    }
    forward_dense(F + (size_t)ne * (size_t)n + (size_t)ne, n - ne, n, y + ne, y + ne);
}

/* x = A^-1 b: forward_eliminated, the back substitution in the factor's order, x = P^T of it */
static void solve_eliminated(const fg_ws *w, const fg_real *F, const fg_real *b, fg_real *x)
{
    int n = FG_N(w), ne = w->nelim, a, b_, j, k;
    fg_real *y = w->etmp;
    forward_eliminated(w, F, b, y);
    backward_dense(F + (size_t)ne * (size_t)n + (size_t)ne, n - ne, n, y + ne);
    for (b_ = 0; b_ < w->nblocks; ++b_) {
        const int *blk = w->blocks + 3 * b_;
        int s = blk[0], e = s + blk[1], kh = blk[2];
        for (k = e - 1; k >= s; --k) {
            const fg_real *Fk = F + (size_t)k * (size_t)n;
            fg_real t = y[k] - dot(Fk + ne, y + ne, kh);
            for (j = k + 1; j < e; ++j)
                t -= Fk[j] * y[j];
            y[k] = t * (1.0 / Fk[k]);
        }
    }
    for (a = 0; a < n; ++a)
        x[w->perm[a]] = y[a];
}

/* x = A^-1 b by LU with partial pivoting (the symmetric A, its lower triangle, copied into F);
 * 0 if A is singular */
static int lu_solve_builtin(const fg_real *A, fg_real *F, int *piv, int n, const fg_real *b,
                            fg_real *x)
{
    int i, j, k;
    sym_copy(F, A, n);
    for (k = 0; k < n; ++k) {
        int pk = k;
        fg_real big = fabs(F[k * n + k]);
        for (i = k + 1; i < n; ++i)
            if (fabs(F[i * n + k]) > big) {
                big = fabs(F[i * n + k]);
                pk = i;
            }
        if (big == 0.0)
            return 0;
        piv[k] = pk;
        if (pk != k)
            for (j = 0; j < n; ++j) {
                fg_real t = F[k * n + j];
                F[k * n + j] = F[pk * n + j];
                F[pk * n + j] = t;
            }
        for (i = k + 1; i < n; ++i) {
            fg_real m = F[i * n + k] / F[k * n + k];
            F[i * n + k] = m;
            if (m != 0.0)
                for (j = k + 1; j < n; ++j)
                    F[i * n + j] -= m * F[k * n + j];
        }
    }
    memcpy(x, b, sizeof(fg_real) * (size_t)n);
    for (k = 0; k < n; ++k) {
        fg_real t = x[piv[k]];
        x[piv[k]] = x[k];
        x[k] = t;
    }
    for (i = 0; i < n; ++i)
        for (k = 0; k < i; ++k)
            x[i] -= F[i * n + k] * x[k];
    for (i = n - 1; i >= 0; --i) {
        for (k = i + 1; k < n; ++k)
            x[i] -= F[i * n + k] * x[k];
        x[i] /= F[i * n + i];
    }
    return 1;
}

/* The factorizations the solver uses: LAPACK's when given and n is large enough, else the
 * built-in ones. K is symmetric, so its row-major storage is also its column-major storage. */
#ifndef FG_SINGLE
static int use_lapack(const fg_problem *p, int n)
{
    return p->lapack.potrf != NULL && n >= p->settings.lapack_min_size;
}
#endif

/* F = the Cholesky factor of A (n = FG_N(w): in elimination order when w->nelim, else the
 * natural one); 0 if A is not positive definite */
static int cholesky(const fg_ws *w, const fg_real *A, fg_real *F)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i;
    if (w->nelim > 0)
        return cholesky_eliminated(w, A, F);
    for (i = 0; i < n; ++i)
        memcpy(F + (size_t)i * (size_t)n + i, A + (size_t)i * (size_t)n + i,
               sizeof(fg_real) * (size_t)(n - i));
#ifndef FG_SINGLE   /* LAPACK takes doubles */
    if (use_lapack(p, n)) {
        char uplo = 'L';          /* column-major lower: the row-major upper triangle */
        int info = 0, lda = n;
        p->lapack.potrf(&uplo, &n, F, &lda, &info);
        return info == 0;
    }
#endif
    (void)p;                  /* (single precision: no LAPACK) */
    return factor_builtin(F, n, n);
}

/* x = A^-1 b with A = U^T U, U in F (cholesky's factor; built-in and dpotrf's have the same
 * layout): U^T y = b, U x = y */
static void cholesky_solve(const fg_ws *w, const fg_real *F, const fg_real *b, fg_real *x)
{
    if (w->nelim > 0) {
        solve_eliminated(w, F, b, x);
        return;
    }
    forward_dense(F, FG_N(w), FG_N(w), b, x);
    backward_dense(F, FG_N(w), FG_N(w), x);
}

/* y = U^-T P b (y is not b; P: the elimination order, or none): the columns whose dot
 * products are J K^-1 J^T */
static void cholesky_forward(const fg_ws *w, const fg_real *F, const fg_real *b, fg_real *y)
{
    if (w->nelim > 0)
        forward_eliminated(w, F, b, y);
    else
        forward_dense(F, FG_N(w), FG_N(w), b, y);
}

static int lu_solve(const fg_problem *p, const fg_real *A, fg_real *F, int *piv, int n,
                    const fg_real *b, fg_real *x)
{
    (void)p;
#ifndef FG_SINGLE   /* LAPACK takes doubles */
    if (use_lapack(p, n)) {
        char trans = 'N';
        int info = 0, lda = n, nrhs = 1;
        sym_copy(F, A, n);
        p->lapack.getrf(&n, &n, F, &lda, piv, &info);
        if (info != 0)
            return 0;
        memcpy(x, b, sizeof(fg_real) * (size_t)n);
        p->lapack.getrs(&trans, &n, &nrhs, F, &lda, piv, x, &lda, &info);
        return info == 0;
    }
#endif
    return lu_solve_builtin(A, F, piv, n, b, x);
}

static fg_real norm2(const fg_real *x, int n)
{
    fg_real s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        s += x[i] * x[i];
    return sqrt(s);
}

static fg_real norm_inf(const fg_real *x, int n)
{
    fg_real s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        if (fabs(x[i]) > s)
            s = fabs(x[i]);
    return s;
}

/* ---- symmetric eigen-decomposition (built-in cyclic Jacobi, or LAPACK's dsyev) ----------- */

/* The cyclic Jacobi method: the eigenvalues of the symmetric A ascending in ev, the eigenvector
 * of ev[j] in row j of V; scratch: 2 n n. Rotations stop when every off-diagonal entry is below
 * 1e-18 of |A| (the eigenvalues are then as accurate as LAPACK's, to a few ulps of |A|). */
static void jacobi_builtin(const fg_real *A, int n, fg_real *ev, fg_real *V, fg_real *scratch)
{
    fg_real *a = scratch, *u = scratch + (size_t)n * (size_t)n, fro = 0.0, small;
    int i, j, k, sweep, rotated = 1;
    sym_copy(a, A, n);
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            u[i * n + j] = i == j ? 1.0 : 0.0;
            fro += a[i * n + j] * a[i * n + j];
        }
    small = FG_JACOBI_SMALL * sqrt(fro);
    for (sweep = 0; sweep < FG_JACOBI_SWEEPS && rotated; ++sweep) {
        rotated = 0;
        for (i = 0; i + 1 < n; ++i)
            for (j = i + 1; j < n; ++j) {
                fg_real aij = a[i * n + j], theta, t, c, s;
                if (aij == 0.0)
                    continue;
                if (fabs(aij) <= small) {
                    a[i * n + j] = a[j * n + i] = 0.0;
                    continue;
                }
                rotated = 1;
                theta = (a[j * n + j] - a[i * n + i]) / (2.0 * aij);
                t = fabs(theta) > 1e150 ? 0.5 / fabs(theta)
                                        : 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0));
                if (theta < 0.0)
                    t = -t;
                c = 1.0 / sqrt(t * t + 1.0);
                s = t * c;
                a[i * n + i] -= t * aij;
                a[j * n + j] += t * aij;
                a[i * n + j] = a[j * n + i] = 0.0;
                for (k = 0; k < n; ++k) {
                    fg_real x, y;
                    if (k != i && k != j) {
                        x = a[k * n + i];
                        y = a[k * n + j];
                        a[k * n + i] = a[i * n + k] = c * x - s * y;
                        a[k * n + j] = a[j * n + k] = s * x + c * y;
                    }
                    x = u[k * n + i];
                    y = u[k * n + j];
                    u[k * n + i] = c * x - s * y;
                    u[k * n + j] = s * x + c * y;
                }
            }
    }
    /* ascending: the smallest remaining diagonal entry next, its column of u as a row of V */
    for (j = 0; j < n; ++j)
        ev[j] = a[j * n + j];
    for (j = 0; j < n; ++j) {
        int m = j;
        fg_real tmp;
        for (k = j + 1; k < n; ++k)
            if (ev[k] < ev[m])
                m = k;
        tmp = ev[j];
        ev[j] = ev[m];
        ev[m] = tmp;
        for (k = 0; k < n; ++k) {
            tmp = u[k * n + j];
            u[k * n + j] = u[k * n + m];
            u[k * n + m] = tmp;
        }
    }
    for (j = 0; j < n; ++j)
        for (k = 0; k < n; ++k)
            V[j * n + k] = u[k * n + j];
}

/* eigenvalues of the symmetric A ascending in w->ew, the eigenvector of ew[j] in row j of w->eV:
 * LAPACK's dsyev when given and n is large enough (its column-major eigenvectors are the rows of
 * the row-major V), else the built-in Jacobi method */
static void eigen(fg_ws *w, const fg_real *A)
{
    const fg_problem *p = w->p;
    int n = FG_N(w);
    (void)p;                  /* (single precision: no LAPACK) */
#ifndef FG_SINGLE   /* LAPACK takes doubles */
    if (p->lapack.syev != NULL && n >= p->settings.lapack_min_size) {
        char jobz = 'V', uplo = 'L';   /* column-major lower: the row-major upper triangle */
        int info = 0, lda = n, lwork = FG_LWORK(n);
        memcpy(w->eV, A, sizeof(fg_real) * (size_t)n * (size_t)n);
        p->lapack.syev(&jobz, &uplo, &n, w->eV, &lda, w->ew, w->ework, &lwork, &info);
        if (info == 0)
            return;
    }
#endif
    jacobi_builtin(A, n, w->ew, w->eV, w->ework);
}

/* the smallest eigenvalue of A; its eigenvector is row 0 of w->eV */
static fg_real min_eig(fg_ws *w, const fg_real *A)
{
    eigen(w, A);
    return FG_N(w) > 0 ? w->ew[0] : 0.0;
}

/* ---- Newton with a line search: plain, or with descent to a stable state ---------------- */

enum { STEP_SINGULAR, STEP_LU, STEP_CHOLESKY };

/* d = K^-1 r: by Cholesky into w->la when K is positive definite (the usual case, half the work
 * of LU), else by LU (partial pivoting); STEP_SINGULAR if K is singular, else which factor
 * w->la holds. factored: w->la already holds K's Cholesky factor. The two agree to rounding. */
static int newton_step(fg_ws *w, const fg_state *st, int factored, fg_real *d)
{
    const fg_problem *p = w->p;
    int n = FG_N(w);
    if (factored || cholesky(w, st->K, w->la)) {
        cholesky_solve(w, w->la, st->r, d);
        return STEP_CHOLESKY;
    }
    return lu_solve(p, st->K, w->la, w->piv, n, st->r, d) ? STEP_LU : STEP_SINGULAR;
}

/* st moved to q - d (d = K^-1 r, a full Newton step) without an evaluation: q, the output
 * points' poses (pose - J d) and r (r - K d, zero to rounding) updated to first order, rel set
 * to the predicted residual; K, the Jacobians and the energies stay at the old q (off by O(|d|),
 * here below 1e-10 relative). Newton's last step, whose evaluation would only confirm it. */
static void step_linearized(fg_ws *w, fg_state *st, const fg_real *d, fg_real rel)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), i, j, a;
    for (j = 0; j < FG_NOUTPUTS(p); ++j) {
        fg_real *o = st->out + (size_t)j * (3 + 3 * (size_t)n);
        for (a = 0; a < 3; ++a)
            o[a] -= dot(o + 3 + (size_t)a * (size_t)n, d, n);
    }
    for (i = 0; i < n; ++i) {     /* r -= K d from K's upper triangle, row by row */
        const fg_real *Ki = st->K + (size_t)i * (size_t)n;
        fg_real di = d[i];
        st->r[i] -= Ki[i] * di + dot(Ki + i + 1, d + i + 1, n - i - 1);
        for (j = i + 1; j < n; ++j)
            st->r[j] -= Ki[j] * di;
    }
    for (i = 0; i < n; ++i)
        st->q[i] -= d[i];
    st->rel = rel;
}

/* Newton from *cur (evaluated) at its load factor, using *spare (and, for descent, *extra) for
 * trial states; on success *cur points at the converged state and the others at spare buffers.
 * Plain: Newton steps with a backtracking line search on |r|, given up when the residual
 * stagnates. Descent (extra != NULL): every step a descent direction of Pi (the eigenvalues of K
 * replaced by their magnitudes, at least eigenvalue_floor of the largest), an Armijo line search
 * on Pi that also takes a step changing Pi by rounding only if it lowers |r|, and, along negative
 * curvature, steps doubled while Pi keeps falling; it ends at a stable equilibrium or fails.
 * factored (plain only): w->la holds the Cholesky factor of (*cur)->K. On failure the last
 * error says why. */
static int newton(fg_ws *w, fg_state **cur, fg_state **spare, fg_state **extra, int max_it,
                  int factored, int *iterations)
{
    const fg_settings *set = w->set;
    int n = FG_N(w), k, i, tries, descent = extra != NULL;
    int lag = set->stagnation_lag, ring = lag + 1;
    fg_real *history = w->hist;      /* the relative residuals of the last lag + 1 iterations */
    w->la_factors_cur = 0;
    for (k = 0; k <= max_it; ++k) {
        fg_state *st = *cur;
        fg_real rn, slope = 0.0, top = 0.0, *d = w->vec3, *qt = w->vec4, alpha = 1.0;
        fg_real floor_;
        int accepted = 0, indefinite = 0, step;
        /* descent ends at a stable equilibrium only: beside a bifurcation the energy is so
         * flat that the start b +- eps v of cross_bifurcation may already be an equilibrium to
         * tol (the float twin's 2e-5: its descents both ended on the unstable branch, and the
         * solve failed, wherever a load step landed just past the critical load) */
        if (st->rel <= set->tol && (!descent || cholesky(w, st->K, w->la)))
            return 1;
        if (k == max_it)
            break;
        history[k % ring] = st->rel;
        if (!descent && k >= set->stagnation_after && k >= lag
            && st->rel > set->stagnation_ratio * history[(k - lag) % ring]) {
            set_error(w, FG_ERR_STAGNATION, st->lam, st->rel);
            return 0;
        }
        ++*iterations;
        rn = norm2(st->r, n);
        if (descent) {
            /* d = -V diag(1 / max(|w|, floor top)) V^T r */
            fg_real *ew = w->ew, *V = w->eV, *c = w->cvec;
            int j;
            eigen(w, st->K);
            for (j = 0; j < n; ++j)
                if (fabs(ew[j]) > top)
                    top = fabs(ew[j]);
            if (top < FG_TINY)
                top = FG_TINY;
            floor_ = set->eigenvalue_floor * top;
            indefinite = n > 0 && ew[0] <= floor_;
            for (j = 0; j < n; ++j) {
                fg_real wm = fabs(ew[j]) > floor_ ? fabs(ew[j]) : floor_;
                c[j] = dot(V + (size_t)j * (size_t)n, st->r, n) / wm;
            }
            for (i = 0; i < n; ++i) {
                fg_real s = 0.0;
                for (j = 0; j < n; ++j)
                    s += V[(size_t)j * (size_t)n + i] * c[j];
                d[i] = -s;
            }
            slope = dot(st->r, d, n);
        } else if ((step = newton_step(w, st, factored && k == 0, d)) == STEP_SINGULAR) {
            /* singular K: no Newton step exists (not reached in practice) */
            set_error(w, FG_ERR_LINE_SEARCH, st->lam, st->rel);
            return 0;
        } else if (k >= 1) {
            /* the last step taken unevaluated: when the residuals seen converge so fast that
             * the step's end is predicted below tol and polish_target (quadratic convergence,
             * its constant from the last two residuals: rel_k^3 / rel_k-1^2) and the step is
             * short enough for the stiffness and Jacobians at its start (rel_k at most
             * linearized_step tol: the compliance is off by about rel_k; measured, a 1e-9
             * residual left it 5e-9 off on a 16-element chain), that end is the equilibrium,
             * its state linearized along
             * d (the evaluation there would only confirm it: one chain evaluation fewer per
             * Newton solve) */
            fg_real prev = history[(k - 1) % ring];
            fg_real predicted = prev > 0.0 ? st->rel / prev * (st->rel / prev) * st->rel : INFINITY;
            if (predicted <= set->tol && predicted <= set->polish_target
                && st->rel <= set->linearized_step * set->tol) {
                step_linearized(w, st, d, predicted);
                w->la_factors_cur = step == STEP_CHOLESKY;    /* st->K's, which stays */
                return 1;
            }
        }
        for (tries = 0; tries < set->line_search_halvings && !accepted; ++tries, alpha *= 0.5) {
            fg_state *trial = *spare;
            if (descent)
                for (i = 0; i < n; ++i)
                    qt[i] = st->q[i] + alpha * d[i];
            else
                for (i = 0; i < n; ++i)
                    qt[i] = st->q[i] - alpha * d[i];
            if (!evaluate(w, qt, st->lam, trial))
                continue;
            if (!descent) {
                if (norm2(trial->r, n) <= (1.0 - set->armijo * alpha) * rn) {
                    *spare = st;
                    *cur = trial;
                    accepted = 1;
                }
                continue;
            }
            {
                int ok = trial->Pi <= st->Pi + set->armijo * alpha * slope;
                int roundoff = fabs(trial->Pi - st->Pi)
                                   <= set->roundoff_tol * (fabs(st->Pi) + fabs(st->U))
                               && norm2(trial->r, n) < rn;
                fg_state *best = trial, *cand = *extra;
                if (!(ok || roundoff))
                    continue;
                if (ok && indefinite && alpha >= 1.0) {
                    /* negative curvature: expand while the potential keeps falling */
                    fg_real a = alpha;
                    int e;
                    for (e = 0; e < set->expansion_doublings; ++e) {
                        a *= 2.0;
                        for (i = 0; i < n; ++i)
                            qt[i] = st->q[i] + a * d[i];
                        if (!evaluate(w, qt, st->lam, cand) || cand->Pi >= best->Pi)
                            break;
                        {
                            fg_state *tmp = best;
                            best = cand;
                            cand = tmp;
                        }
                    }
                }
                /* best becomes the current state; st and the other buffer the spares */
                *cur = best;
                *spare = st;
                *extra = cand;
                accepted = 1;
            }
        }
        if (!accepted) {
            set_error(w, FG_ERR_LINE_SEARCH, st->lam, st->rel);
            return 0;
        }
    }
    set_error(w, FG_ERR_NOT_CONVERGED, (*cur)->lam, (*cur)->rel);
    w->err_iterations = max_it;
    return 0;
}

/* q is the q of the last kinematics (which succeeded): their kernel choices (kin_kernel) hold */
static int at_kinematics(const fg_ws *w, const fg_real *q)
{
    return w->kin_ok && (q == w->kq || memcmp(q, w->kq, sizeof(fg_real) * (size_t)FG_N(w)) == 0);
}

/* which of its first kernels evaluates kernel flexure i at q (all coordinates): FG_KERNEL_LOCAL
 * where its local kernel certifies q, else FG_KERNEL_POLY within its polynomial kernel's range,
 * else 0 (the Gauss kernel would); known: q is the last kinematics' (at_kinematics), which asked
 * the same there */
static int first_kernel(const fg_ws *w, int i, const fg_real *q, int known)
{
    const fg_flexure *f = &w->p->flex[i];
    const fg_real *qf = q + f->offset;
    if (known)
        return w->kin_kernel[i] == FG_KERNEL_GAUSS ? 0 : w->kin_kernel[i];
    if (f->local != NULL && f->local_in_range(qf))
        return FG_KERNEL_LOCAL;
    if (f->poly != NULL && f->in_range(qf))
        return FG_KERNEL_POLY;
    return 0;
}

/* every smooth curvature flexure within its range: the set of its first kernels (local,
 * polynomial) when it has one (an "auto" flexure past it would switch kernels), else the Gauss
 * kernel's certified range */
static int in_kernel_range(const fg_ws *w, const fg_real *q)
{
    const fg_problem *p = w->p;
    int i, known = at_kinematics(w, q);
    for (i = 0; i < FG_NFLEX(p); ++i) {
        const fg_flexure *f = &p->flex[i];
        if (f->kind != FG_MODEL_KERNEL)
            continue;
        if (f->poly != NULL || f->local != NULL) {
            if (!first_kernel(w, i, q, known))
                return 0;
        } else if (f->gauss_in_range != NULL && !f->gauss_in_range(q + f->offset))
            return 0;
    }
    return 1;
}

/* ---- the solve ---------------------------------------------------------------------------- */

/* polish the equilibrium *cur, then the answer: q, the output points' poses and compliances.
 * factor: NULL, or the Cholesky factor of cur->K in w->lb (end_factor_of), used by the first
 * polishing step and, if no step is taken, for the stability and the compliance. */
static int finish(fg_ws *w, fg_state *cur, fg_state *spare, fg_real *factor,
                  int iterations, fg_answer *out)
{
    const fg_problem *p = w->p;
    const fg_settings *set = w->set;
    int n = FG_N(w), i, j, a;
    fg_real *F = NULL;             /* cur->K's Cholesky factor, when known */
    /* polish: plain Newton steps while they lower the relative residual below polish_target
     * (K^-1 r by Cholesky where K is positive definite, else by LU: the two agree to rounding) */
    if (factor != NULL)
        F = factor;
    for (j = 0; j < set->polish_steps && cur->rel > set->polish_target; ++j) {
        fg_real *d = w->vec3, *qt = w->vec4;
        if (F != NULL)
            cholesky_solve(w, F, cur->r, d);
        else if (!newton_step(w, cur, 0, d))
            break;
        for (i = 0; i < n; ++i)
            qt[i] = cur->q[i] - d[i];
        if (!evaluate(w, qt, 1.0, spare) || !(spare->rel < cur->rel))
            break;
        ++iterations;
        {
            fg_state *tmp = cur;
            cur = spare;
            spare = tmp;
        }
        F = NULL;
    }

    /* the answer: the output points' kinematics saved with the state (no evaluation), the
     * compliance J K^-1 J^T of each */
    if (F != NULL) {
        out->stable = 1;
        if (F == w->lb) {           /* the factor into la by trading the two scratch places */
            w->lb = w->la;
            w->la = F;
        } else if (F != w->la)
            memcpy(w->la, F, sizeof(fg_real) * (size_t)n * (size_t)n);
    } else {
        out->stable = cholesky(w, cur->K, w->la);
    }
    out->iterations = iterations;
    out->undefined_compliance = 0;
    out->energy = cur->U;
    out->residual = cur->rel;
    memcpy(out->q, cur->q, sizeof(fg_real) * (size_t)n);
    if (out->stiffness != NULL)
        sym_copy(out->stiffness, cur->K, n);
    for (j = 0; j < FG_NOUTPUTS(p); ++j) {
        const fg_real *J = cur->out + (size_t)j * (3 + 3 * (size_t)n) + 3;
        /* stable (K = U^T U): C = Y^T Y with Y = U^-T J^T, half a solve per column and
         * symmetric by construction; else C = J X, X = K^-1 J^T by LU, symmetrized */
        fg_real *C = out->compliance + 9 * j, *X = w->lc;   /* Y or X: 3 columns */
        int ok = 1, stable = out->stable;
        memcpy(out->pose + 3 * j, J - 3, sizeof(fg_real) * 3);
        for (a = 0; a < 3 && ok; ++a) {
            if (stable)
                cholesky_forward(w, w->la, J + a * n, X + a * n);
            else
                ok = lu_solve(p, cur->K, w->lb, w->piv, n, J + a * n, X + a * n);
        }
        for (a = 0; a < 3; ++a)
            for (i = 0; i < 3; ++i) {
                if (!ok)
                    C[a * 3 + i] = NAN;
                else if (stable)
                    C[a * 3 + i] = i < a ? C[i * 3 + a] : dot(X + a * n, X + i * n, n);
                else
                    C[a * 3 + i] = dot(J + a * n, X + i * n, n);
            }
        if (!stable)
            for (a = 0; a < 3; ++a)
                for (i = 0; i < a; ++i) {
                    fg_real s = 0.5 * (C[a * 3 + i] + C[i * 3 + a]);
                    C[a * 3 + i] = C[i * 3 + a] = s;
                }
        if (!finite_all(C, 9))
            ++out->undefined_compliance;
        if (out->ellipse != NULL) {
            fg_real C2[4];
            C2[0] = C[0];
            C2[1] = C[1];
            C2[2] = C[3];
            C2[3] = C[4];
            fg_ellipse(C2, set->circle_tol, out->ellipse + 3 * j);
        }
    }
    return FG_SOLVED;
}

/* No force and no tendon under tension, only moments: every frame's angle is linear in q (each
 * model's tip angle is: the curvature kernels', the n-element chain's, the pseudo-rigid body's),
 * so the loads' Hessians vanish, S = 0 at every q, K is the elastic stiffness and Q constant:
 * the equilibrium path is a straight line, and any state on it is known without the chain. */
static int linear_path(const fg_problem *p)
{
    int i;
    for (i = 0; i < FG_NLOADS(p); ++i)
        if (p->load[3 * i] != 0.0 || p->load[3 * i + 1] != 0.0)
            return 0;
    for (i = 0; i < FG_NTENDONS(p); ++i)
        if (p->tension[i] != 0.0)
            return 0;
    return 1;
}

/* w->lb = the Cholesky factor of st->K, st the state newton just returned; 0 if st->K is not
 * positive definite. When newton's last step was linearized, w->la already holds that factor
 * (K stays that of the step's start): la and lb trade places instead of a second factorization
 * (both are n x n scratch of this call's workspace). */
static int end_factor_of(fg_ws *w, const fg_state *st)
{
    if (w->la_factors_cur) {
        fg_real *t = w->la;
        w->la = w->lb;
        w->lb = t;
        w->la_factors_cur = 0;
        return 1;
    }
    return cholesky(w, st->K, w->lb);
}

/* The largest change d makes to an angle along a flexure, over the flexures: a fem flexure's
 * coordinates are its joints' angles, each a small part of its bend, so its angles along it
 * change by the sums of d over its first joints (the largest of them); a kernel flexure's and
 * a pseudo-rigid body's coordinates are each a bend of their own (|d| per coordinate). The
 * measure of the path checks' steps (on_load_path, the warm start): per coordinate, a fem
 * chain of 16 elements could move its tip by 16 times the bound (review: warm fem solves
 * accepted the other branch of a buckled column, 1.3 L away). */
static fg_real angle_change(const fg_ws *w, const fg_real *d)
{
    const fg_problem *p = w->p;
    fg_real most = 0.0;
    int i, j;
    for (i = 0; i < FG_NFLEX(p); ++i) {
        const fg_flexure *f = &p->flex[i];
        int k = FG_FLEX_NDOF(f);
        const fg_real *di = d + f->offset;
        if (f->kind == FG_MODEL_FEM) {
            fg_real sum = 0.0;
            for (j = 0; j < k; ++j) {
                sum += di[j];
                if (!(fabs(sum) <= most)) {
                    most = fabs(sum);
                    if (isnan(most))     /* a NaN is the result (no later value undoes it) */
                        return most;
                }
            }
        } else {
            for (j = 0; j < k; ++j)
                if (!(fabs(di[j]) <= most)) {
                    most = fabs(di[j]);
                    if (isnan(most))
                        return most;
                }
        }
    }
    return most;
}

/* q = the point at fraction t of the cubic Hermite path from qa to qb over a load-factor step
 * dl, its end tangents dq/dlam ta and tb (n coordinates) */
static void hermite_point(int n, const fg_real *qa, const fg_real *ta, const fg_real *qb,
                          const fg_real *tb, fg_real dl, fg_real t, fg_real *q)
{
    fg_real h00 = 2 * t * t * t - 3 * t * t + 1, h10 = (t * t * t - 2 * t * t + t) * dl;
    fg_real h01 = -2 * t * t * t + 3 * t * t, h11 = (t * t * t - t * t) * dl;
    int i;
    for (i = 0; i < n; ++i)
        q[i] = h00 * qa[i] + h10 * ta[i] + h01 * qb[i] + h11 * tb[i];
}

/* 1 if the point at fraction t of the cubic Hermite path from (qa, lam_a) to (qb, lam_b), its end
 * tangents dq/dlam ta and tb, is near an equilibrium of that path: the state there (at lam_a +
 * t (lam_b - lam_a)) positive definite and its Newton correction at most direct_correction
 * max_dq. in_range: the point also in its first kernel's range (else it evaluates whatever
 * kernel covers it). The sample's state goes to *smp, its factor to w->la; the caller saves
 * and restores the flags and errors its evaluation leaves. */
static int hermite_sample_near(fg_ws *w, const fg_real *qa, const fg_real *ta, fg_real lam_a,
                               const fg_real *qb, const fg_real *tb, fg_real lam_b, fg_real t,
                               fg_state *smp, int in_range)
{
    const fg_settings *set = w->set;
    int evaluated;
    fg_real dl = lam_b - lam_a, *qt = w->vec4, *corr = w->vec3;
    hermite_point(FG_N(w), qa, ta, qb, tb, dl, t, qt);
    if (in_range && !in_kernel_range(w, qt))
        return 0;
    w->poly_in_range = in_range;  /* in range (above): in_range is not asked again */
    evaluated = evaluate(w, qt, lam_a + t * dl, smp);
    w->poly_in_range = 0;
    if (!evaluated || !cholesky(w, smp->K, w->la))
        return 0;
    cholesky_solve(w, w->la, smp->r, corr);
    return angle_change(w, corr) <= set->direct_correction * set->max_dq;
}

/* 1 if the equilibrium *c at the full load (w->lb: the Cholesky factor of c->K) is on the load
 * path from the unloaded state *st0 (K(q0, 0) diagonal, positive definite), as far as
 * direct_samples points of the cubic Hermite path between the two (its end tangents dq/dlam
 * the path's: K^-1 Q at each end) tell: at each, K positive definite and a Newton correction
 * of at most direct_correction max_dq (hermite_sample_near). in_range: every sample also in
 * its first kernel's range (the direct solve: a path that switches kernels is the
 * continuation's, which reports the switches); else a sample evaluates whatever kernel covers
 * it. The samples' evaluations leave the flags and errors as the caller saved them (the caller
 * restores them). */
static int on_load_path(fg_ws *w, const fg_state *st0, const fg_state *c, fg_state *smp,
                        int in_range)
{
    const fg_settings *set = w->set;
    int n = FG_N(w), i, j, linear = linear_path(w->p);
    fg_real *t0 = w->t0, *t1 = w->t1;     /* path tangents dq/dlam at the two ends */
    for (i = 0; i < n; ++i)                       /* K(q0, 0) is diagonal (the caller) */
        t0[i] = st0->Q[i] / st0->K[(size_t)i * (size_t)n + i];
    cholesky_solve(w, w->lb, c->Q, t1);
    for (j = 1; j <= set->direct_samples; ++j) {
        fg_real t = (fg_real)j / (set->direct_samples + 1), *qt = w->vec4, *corr = w->vec3;
        if (!linear) {
            if (!hermite_sample_near(w, st0->q, t0, 0.0, c->q, t1, 1.0, t, smp, in_range))
                return 0;
            continue;
        }
        /* K = K(q0, 0) (positive definite, diagonal), Q = Q(q0): the correction without the
         * chain */
        hermite_point(n, st0->q, t0, c->q, t1, 1.0, t, qt);
        if (in_range && !in_kernel_range(w, qt))
            return 0;
        for (i = 0; i < n; ++i) {
            fg_real k = st0->K[(size_t)i * (size_t)n + i];
            corr[i] = (k * qt[i] - t * st0->Q[i]) / k;
        }
        if (!(angle_change(w, corr) <= set->direct_correction * set->max_dq))
            return 0;
    }
    return 1;
}

/* The full load in one Newton solve from the unloaded state *st0: 1 with the equilibrium in
 * *cur if every check passes, else 0 (the continuation runs). The caller checked that st0->K,
 * K at lam = 0 (the elastic stiffness: diagonal), is positive definite. w->lb receives the
 * Cholesky factor of the end state's K, for the polishing and the compliance.
 *
 * The checks, in an order that spends no chain evaluation on an attempt a cheaper check
 * rejects: K(q0, 1) positive definite (from st0's parts: no evaluation); Newton at lam = 1 (its
 * first step solves with that factor: no second factorization); the end state in every kernel's
 * range (before the samples, which cannot change that outcome); K at the end positive definite
 * (the factor is also the polishing's and the compliance's; after a linearized last step it is
 * Newton's own: end_factor_of); then the direct_samples points of
 * the Hermite path: positive definite and a Newton correction of at most direct_correction
 * max_dq, and in range. The attempt passes only if every check does, so their order changes
 * the cost, never the outcome. A rejected attempt leaves no trace: iterations (the caller), the
 * last error, the model error and the kernel-switch flags are restored.
 *
 * Chain evaluations (fg_answer.evaluations). Evaluating every state afresh takes 10 for one
 * scm3 flexure under the tip force of examples/cantilever_tip_load.toml: the unloaded state, 5
 * Newton iterations (relative residuals 0.34, 1.0e-2, 1.2e-5, 1.5e-11 -- just above
 * tol = 1e-12 -- and 1.8e-18; no polishing step follows), 3 samples, and the kinematics of the
 * answer evaluated once more at the end. Shared or skipped here, without changing a check:
 * - the unloaded state evaluates no kernel: its value at q = 0 is a constant of the model
 *   (fg_flexure.tip0, computed once per problem);
 * - Newton's last step (from 1.5e-11, predicted to 2e-23 by the quadratic convergence seen) is
 *   taken without evaluating its end, its state linearized along the step (newton);
 * - the unloaded state's parts give K(q0, 1) and Newton's first state (K is linear in lam);
 * - each state keeps its output points' poses and Jacobians (fg_state.out), so the answer, the
 *   polished state's included, needs no evaluation (finish), nor does the bifurcation's
 *   mean-output tie-break;
 * - a polishing step is taken only while the residual is above polish_target (here none);
 * - a sample is not evaluated where its state is known in closed form: with no force and no
 *   tendon under tension (moments only: linear_path) every frame angle is linear in q, so the
 *   loads' Hessian S vanishes, K is the diagonal elastic stiffness and Q is constant; the sample's
 *   correction K^-1 r = q - t K^-1 Q and its positive definiteness follow without the chain
 *   (its range is still checked: no evaluation).
 * That makes 7 for the tip force: 4 Newton iterations evaluated and 3 samples, all needed. A
 * sample cannot share a Newton state (those are at lam = 1, a sample is at lam = t < 1 on the
 * path), and under a force S(q) changes along the path, so no sample follows from the ends.
 * Fewer would take a weaker check: direct_samples = 1 (one sample, t = 1/2) gives 5. */
static int direct_solve(fg_ws *w, const fg_state *st0, fg_state **cur, fg_state **spare,
                        fg_state *smp, int *iterations)
{
    const fg_settings *set = w->set;
    int n = FG_N(w), ok = 0;
    int max_it = set->max_iterations < set->direct_max_iterations ? set->max_iterations
                                                                   : set->direct_max_iterations;
    fg_state *c = *cur;
    fg_errors saved;

    save_trial(w, &saved);
    memcpy(c->q, st0->q, sizeof(fg_real) * (size_t)n);
    memcpy(c->gU, st0->gU, sizeof(fg_real) * (size_t)n);
    memcpy(c->QL, st0->QL, sizeof(fg_real) * (size_t)n);
    memcpy(c->QT, st0->QT, sizeof(fg_real) * (size_t)n);
    memcpy(c->out, st0->out, sizeof(fg_real) * out_size(w));
    c->U = st0->U;
    c->W = st0->W;
    c->V = st0->V;
    c->gmax = st0->gmax;
    c->rmax = st0->rmax;
    c->sfinite = st0->sfinite;
    /* K(q0, 1) from st0's S, not copied: the states of this solve at lam = 1 never need
     * their S again (Newton, finish: r, K, Pi, out), so c->S is left as it is */
    at_lambda(w, c, st0->S, 1.0, 0);
    if (!state_finite(w, c) || !cholesky(w, c->K, w->la))
        goto done;                /* the full load may buckle the unloaded state */
    if (!newton(w, cur, spare, NULL, max_it, 1, iterations))
        goto done;
    c = *cur;
    if (!in_kernel_range(w, c->q) || !end_factor_of(w, c))
        goto done;
    ok = on_load_path(w, st0, c, smp, 1);
done:
    /* the trial steps and samples are no part of the path: the flags and errors as before */
    restore_trial(w, &saved);
    return ok;
}

/* the length of route entry e's segment in the kinematics last evaluated */
static fg_real segment_length(const fg_ws *w, int e)
{
    const fg_real *A = w->ppose + 3 * w->p->route[e], *B = w->ppose + 3 * w->p->route[e + 1];
    return hypot(B[0] - A[0], B[1] - A[1]);
}

/* Where the load path ended at q: the first tendon segment (under tension, between two bodies)
 * the load pulled shut, at most FG_SHORT_TENDON of the longest flexure long at q and not in the
 * unloaded state, is named as the model error (FG_ERR_TENDON, its route entry): the cause to
 * read before a limit point (review: a link point pulled onto its anchor read as "a limit point
 * with no stable state to snap to"; and a segment short from the start is no such cause). The
 * kinematics at q and at the unloaded state are evaluated (both were on the path: in range);
 * nothing else changes. */
static void name_short_tendon(fg_ws *w, const fg_real *q)
{
    const fg_problem *p = w->p;
    fg_real longest = 0.0, *rest = w->vec4;
    int t, j, at_q;
    for (j = 0; j < FG_NFLEX(p); ++j)
        if (p->flex[j].length > longest)
            longest = p->flex[j].length;
    memset(rest, 0, sizeof(fg_real) * (size_t)FG_N(w));
    if (FG_NTENDONS(p) == 0 || !kinematics(w, q))
        return;
    at_q = 1;
    for (t = 0; t < FG_NTENDONS(p); ++t) {
        if (p->tension[t] == 0.0)
            continue;
        for (j = 0; j + 1 < p->route_len[t]; ++j) {
            int e = p->route_start[t] + j;
            if (one_body_segment(p, e))
                continue;
            if (!at_q && !kinematics(w, q))
                return;
            at_q = 1;
            if (!(segment_length(w, e) <= FG_SHORT_TENDON * longest))
                continue;
            if (!kinematics(w, rest))
                return;
            at_q = 0;
            if (segment_length(w, e) > FG_SHORT_TENDON * longest) {
                w->merr = FG_ERR_TENDON;
                w->merr_flex = -1;
                w->merr_route = e;
                return;
            }
        }
    }
}

/* ---- stability along the path: bifurcations and limit points ---------------------------- */

/* a state of the pool that is none of the given ones (NULL: none given) */
static fg_state *free_state(fg_ws *w, const fg_state *x0, const fg_state *x1,
                            const fg_state *x2, const fg_state *x3)
{
    int i;
    for (i = 0; i < FG_NSTATES; ++i) {
        fg_state *s = &w->st[i];
        if (s != x0 && s != x1 && s != x2 && s != x3)
            return s;
    }
    return NULL;            /* not reached: FG_NSTATES > 4 */
}

/* a critical load factor of this kind, in order: counted always, stored while there is room */
static void record_critical(fg_answer *out, fg_real lam, int kind)
{
    if (out->critical != NULL && out->critical_kind != NULL
        && out->ncritical < out->max_critical) {
        out->critical[out->ncritical] = lam;
        out->critical_kind[out->ncritical] = kind;
    }
    ++out->ncritical;
}

/* Newton with descent from q at load factor lam, up to descent_iteration_factor max_iterations
 * (a snap-through, and the leaving of an unstable branch past a bifurcation); the stable
 * equilibrium it ends at, or NULL. The states keep and keep2 are not touched. */
static fg_state *descend(fg_ws *w, const fg_real *q, fg_real lam, const fg_state *keep,
                         const fg_state *keep2, int *iterations)
{
    fg_state *a = free_state(w, keep, keep2, NULL, NULL);
    fg_state *b = free_state(w, keep, keep2, a, NULL);
    fg_state *c = free_state(w, keep, keep2, a, b);
    if (!evaluate(w, q, lam, a)
        || !newton(w, &a, &b, &c, w->set->descent_iteration_factor * w->set->max_iterations, 0,
                   iterations)
        || !cholesky(w, a->K, w->la))
        return NULL;
    return a;
}

/* At a bifurcation the load does no work along the lost mode v (the eigenvector of K's smallest
 * eigenvalue): |v . Q| <= bifurcation_threshold (|Q| + |lam S|), |lam S| the Frobenius norm of
 * the load part of K. Its sign does not matter. */
static int is_bifurcation(fg_ws *w, const fg_state *b)
{
    int n = FG_N(w), i;
    fg_real kg = 0.0, scale;
    min_eig(w, b->K);
    for (i = 0; i < n; ++i) {     /* S's upper triangle: the strict part counts twice */
        int j;
        for (j = i; j < n; ++j) {
            fg_real g = b->lam * b->S[(size_t)i * (size_t)n + j];
            kg += j > i ? 2.0 * (g * g) : g * g;
        }
    }
    scale = norm2(b->Q, n) + sqrt(kg);
    return scale > 0.0 ? fabs(dot(w->eV, b->Q, n)) <= w->set->bifurcation_threshold * scale : 1;
}

/* the mean world y and angle of the output points at s (saved with the state) */
static void mean_output(fg_ws *w, const fg_state *s, fg_real *y, fg_real *angle)
{
    const fg_problem *p = w->p;
    int j;
    size_t stride = 3 + 3 * (size_t)FG_N(w);
    *y = *angle = 0.0;
    if (FG_NOUTPUTS(p) == 0)
        return;
    for (j = 0; j < FG_NOUTPUTS(p); ++j) {
        *y += s->out[stride * (size_t)j + 1];
        *angle += s->out[stride * (size_t)j + 2];
    }
    *y /= FG_NOUTPUTS(p);
    *angle /= FG_NOUTPUTS(p);
}

/* The path went from the stable *a through a bifurcation to the unstable *b: the critical load
 * factor by regula falsi (Illinois) on the smallest eigenvalue with Newton at each trial load
 * factor, then the stable side at b's load factor, by descent from b +- eps v (eps =
 * descent_eps max(1, |q_b|)): the only stable one found, else the one of lower potential, else
 * (symmetric) the one whose output points lie higher (mean world y), else the counter-clockwise
 * one. The chosen state (in the pool) with the critical load factor recorded, or NULL. */
static fg_state *cross_bifurcation(fg_ws *w, fg_state *a, fg_state *b, int *iterations,
                                   fg_answer *out)
{
    const fg_settings *set = w->set;
    int n = FG_N(w), i, it, side = 0, why;
    fg_state *lo = a, *hi = b, *s1, *s2, *choice;
    fg_real mu_lo = min_eig(w, a->K), mu_hi = min_eig(w, b->K);
    fg_real e_lo = mu_lo, e_hi = mu_hi;       /* the eigenvalues themselves (no Illinois halving) */
    fg_real lam_c, eps, lam_b = b->lam, *qm = w->t1, *v = w->vmin;
    for (it = 0; it < set->bracket_iterations; ++it) {
        fg_real t, lam_m, mu_m, kmax = 1.0;
        fg_state *m, *m2;
        if (hi->lam - lo->lam <= set->bracket_tol * (hi->lam > 1.0 ? hi->lam : 1.0))
            break;
        t = mu_lo != mu_hi ? mu_lo / (mu_lo - mu_hi) : 0.5;
        t = t > set->bracket_clamp ? t : set->bracket_clamp;
        t = t < 1.0 - set->bracket_clamp ? t : 1.0 - set->bracket_clamp;
        lam_m = lo->lam + t * (hi->lam - lo->lam);
        for (i = 0; i < n; ++i)
            qm[i] = lo->q[i] + t * (hi->q[i] - lo->q[i]);
        m = free_state(w, lo, hi, b, NULL);
        m2 = free_state(w, lo, hi, b, m);
        if (!evaluate(w, qm, lam_m, m)
            || !newton(w, &m, &m2, NULL, set->max_iterations, 0, iterations))
            break;
        mu_m = min_eig(w, m->K);
        if (mu_m == 0.0) {
            lo = hi = m;
            e_lo = e_hi = mu_m;
            break;
        }
        if (mu_m > 0.0) {
            lo = m;
            mu_lo = e_lo = mu_m;
            if (side == -1)
                mu_hi *= 0.5;
            side = -1;
        } else {
            hi = m;
            mu_hi = e_hi = mu_m;
            if (side == 1)
                mu_lo *= 0.5;
            side = 1;
        }
        for (i = 0; i < n; ++i) {             /* K's upper triangle */
            int j;
            for (j = i; j < n; ++j)
                if (fabs(m->K[(size_t)i * (size_t)n + j]) > kmax)
                    kmax = fabs(m->K[(size_t)i * (size_t)n + j]);
        }
        if (fabs(mu_m) <= set->bracket_tol * kmax)
            break;
    }
    lam_c = e_lo == e_hi ? lo->lam : lo->lam + e_lo / (e_lo - e_hi) * (hi->lam - lo->lam);

    /* leave the unstable branch at b's load factor: descend from b +- eps v */
    min_eig(w, b->K);
    memcpy(v, w->eV, sizeof(fg_real) * (size_t)n);
    eps = set->descent_eps * (norm2(b->q, n) > 1.0 ? norm2(b->q, n) : 1.0);
    for (i = 0; i < n; ++i) {
        w->qplus[i] = b->q[i] + eps * v[i];
        w->qminus[i] = b->q[i] + (-eps) * v[i];
    }
    s1 = descend(w, w->qplus, lam_b, NULL, NULL, iterations);
    s2 = descend(w, w->qminus, lam_b, s1, NULL, iterations);
    if (s1 == NULL && s2 == NULL)
        return NULL;
    if (s1 == NULL || s2 == NULL) {
        choice = s1 != NULL ? s1 : s2;
        why = FG_BUCKLING_ONLY_SIDE;
    } else {
        fg_real scale = FG_TINY, y1, y2, th1, th2, ys;
        if (fabs(s1->Pi) > scale)
            scale = fabs(s1->Pi);
        if (fabs(s2->Pi) > scale)
            scale = fabs(s2->Pi);
        if (fabs(s1->U) > scale)
            scale = fabs(s1->U);
        if (fabs(s2->U) > scale)
            scale = fabs(s2->U);
        if (fabs(s1->Pi - s2->Pi) > set->tie_tol * scale) {
            choice = s1->Pi < s2->Pi ? s1 : s2;
            why = FG_BUCKLING_LOWER_ENERGY;
        } else {
            mean_output(w, s1, &y1, &th1);
            mean_output(w, s2, &y2, &th2);
            ys = fabs(y1) > fabs(y2) ? fabs(y1) : fabs(y2);
            if (fabs(y1 - y2) > set->tie_tol * (ys > FG_TINY ? ys : FG_TINY)) {
                choice = y1 > y2 ? s1 : s2;
                why = FG_BUCKLING_LARGER_Y;
            } else {
                choice = th1 >= th2 ? s1 : s2;
                why = FG_BUCKLING_COUNTER_CLOCKWISE;
            }
        }
    }
    record_critical(out, lam_c, why);
    return choice;
}

/* Load continuation from the state *path (lam = 0) to lam = 1: adaptive steps, a tangent
 * predictor while K is positive definite, Newton at each load factor, a step that changes a
 * coordinate by more than max_dq counts as a jump. A step from a stable state onto an unstable
 * one is a bifurcation (crossed: cross_bifurcation) or else the unstable side of a limit point
 * (a shorter step); where the path ends (no step even at min_step) the solve descends to the
 * equilibrium it snaps to. The equilibrium at lam = 1 (a state of the pool), or NULL with
 * out->failure and out->failure_load_factor set (the step budget runs out, no stable state past
 * a bifurcation or beyond a limit point). */
static fg_state *continuation(fg_ws *w, fg_state *path, int *iterations, fg_answer *out)
{
    const fg_settings *set = w->set;
    int n = FG_N(w), i, steps = 0;
    fg_real lam = 0.0, dlam = set->initial_step;
    while (lam < 1.0) {
        fg_real lam_n = lam + dlam < 1.0 ? lam + dlam : 1.0;
        int it0 = *iterations, used, found = 0, attempt, stable_before;
        fg_state *a = free_state(w, path, NULL, NULL, NULL);
        fg_state *b = free_state(w, path, a, NULL, NULL);
        if (++steps > set->max_steps) {
            out->failure = FG_FAIL_STEPS;
            out->failure_load_factor = lam;
            return NULL;
        }
        stable_before = cholesky(w, path->K, w->la);
        for (attempt = 0; attempt < 2 && !found; ++attempt) {
            fg_real *start = w->vec1;
            if (attempt == 0) {            /* the tangent predictor */
                if (!stable_before)
                    continue;
                cholesky_solve(w, w->la, path->Q, w->t0);
                for (i = 0; i < n; ++i)
                    start[i] = path->q[i] + (lam_n - lam) * w->t0[i];
            } else {
                memcpy(start, path->q, sizeof(fg_real) * (size_t)n);
            }
            if (!evaluate(w, start, lam_n, a)
                || !newton(w, &a, &b, NULL, set->max_iterations, 0, iterations))
                continue;
            for (i = 0; i < n; ++i)
                w->vec2[i] = a->q[i] - path->q[i];
            /* a jump: a coordinate changed by more than max_dq, or (from a stable state) the
             * step went against the path's tangent: near a critical load the tangent points
             * along the branch the path is on (the side an imperfection chose), and Newton from
             * the predictor may land on the other branch of the near-bifurcation */
            found = norm_inf(w->vec2, n) <= set->max_dq
                    && !(stable_before && dot(w->vec2, w->t0, n) < 0.0);
            if (!found)
                set_error(w, FG_ERR_JUMP, lam_n, 0.0);
        }
        used = *iterations - it0;
        if (found && stable_before && !cholesky(w, a->K, w->la)) {
            if (is_bifurcation(w, a)) {
                fg_state *next = cross_bifurcation(w, path, a, iterations, out);
                if (next == NULL) {
                    out->failure = FG_FAIL_BIFURCATION;
                    out->failure_load_factor = lam;
                    return NULL;
                }
                path = next;
                lam = lam_n;
                dlam = set->initial_step;
                continue;
            }
            found = 0;            /* the unstable side of a limit point: a shorter step */
        }
        /* a step between two stable states passes the direct solve's path check at its
         * midpoint (hermite_sample_near): near a limit point Newton from the predictor may
         * converge to a stable equilibrium of another branch within max_dq, past the fold
         * where the path ends and snaps through (review: the float controller twin of a fem8
         * finger stepped from load factor 0.425 to 0.675 across the snap-through at 0.454, and
         * ended 3 lengths from the double solver's answer with no note; the midpoint's
         * correction was 11 times the limit, every regular step's below a quarter of it) */
        if (found && stable_before) {
            fg_errors saved;
            fg_state *mid = free_state(w, path, a, NULL, NULL);
            cholesky_solve(w, w->la, a->Q, w->t1);        /* w->la: a->K's factor (above) */
            save_trial(w, &saved);
            found = hermite_sample_near(w, path->q, w->t0, lam, a->q, w->t1, lam_n, 0.5, mid, 0);
            restore_trial(w, &saved);
            if (!found)
                set_error(w, FG_ERR_JUMP, lam_n, 0.0);
        }
        if (!found) {
            fg_state *next;
            if (dlam > set->min_step) {
                dlam = set->step_shrink * dlam > set->min_step ? set->step_shrink * dlam
                                                               : set->min_step;
                continue;
            }
            /* the path ends here (a limit point): descend to the equilibrium it snaps to */
            next = descend(w, path->q, lam_n, path, NULL, iterations);
            if (next == NULL) {
                out->failure = FG_FAIL_LIMIT;
                out->failure_load_factor = lam;
                name_short_tendon(w, path->q);
                return NULL;
            }
            record_critical(out, lam, FG_SNAP_THROUGH);
            path = next;
            lam = lam_n;
            dlam = set->initial_step;
            continue;
        }
        if (used <= set->fast_iterations)
            dlam = set->fast_growth * dlam < set->max_step ? set->fast_growth * dlam
                                                           : set->max_step;
        else if (used <= set->moderate_iterations)
            dlam = set->moderate_growth * dlam < set->max_step ? set->moderate_growth * dlam
                                                               : set->max_step;
        path = a;
        lam = lam_n;
        clear_model_error(w);
    }
    return path;
}

/* the problem can be run: counts and indices in range, the arrays there (FG_MODEL_ERROR if not) */
static int problem_well_formed(const fg_problem *p)
{
    int i, j;
    if (p->ndof < 0 || p->nflex < 0 || p->npoints < 0 || p->nloads < 0 || p->ntendons < 0
        || p->noutputs < 0 || (p->ndof > 0 && p->stiffness == NULL)
        || (p->noutputs > 0 && p->outputs == NULL)
        || (p->nflex > 0 && p->flex == NULL) || (p->npoints > 0 && p->points == NULL)
        || (p->nloads > 0 && (p->load_point == NULL || p->load == NULL))
        || (p->ntendons > 0 && (p->tension == NULL || p->route_start == NULL
                                || p->route_len == NULL || p->route == NULL))
        || p->settings.stagnation_lag < 1 || p->settings.stagnation_lag > FG_MAX_LAG)
        return 0;
#ifdef FG_FIXED_SIZES
    if (p->ndof != FG_FIXED_NDOF || p->nflex != FG_FIXED_NFLEX || p->npoints != FG_FIXED_NPOINTS
        || p->nloads != FG_FIXED_NLOADS || p->ntendons != FG_FIXED_NTENDONS
        || p->noutputs != FG_FIXED_NOUTPUTS)
        return 0;     /* the sizes this build was compiled for (FG_N ..) */
#endif
    for (i = 0; i < p->nflex; ++i) {
        const fg_flexure *f = &p->flex[i];
        if (f->ndof < 1 || f->offset < 0 || f->offset + f->ndof > p->ndof || f->parent < -1
            || f->parent >= i)
            return 0;
#ifdef FG_FIXED_FLEX_NDOF
        if (f->ndof != FG_FIXED_FLEX_NDOF)
            return 0;
#endif
        if (f->kind == FG_MODEL_KERNEL) {
            if ((f->poly == NULL && f->gauss == NULL) || (f->poly != NULL && f->in_range == NULL))
                return 0;
        } else if (f->kind == FG_MODEL_PRB) {
            if (f->ndof != 1)
                return 0;
        } else if (f->kind != FG_MODEL_FEM) {
            return 0;
        }
    }
    for (i = 0; i < p->npoints; ++i)
        if (p->points[i].frame < -1 || p->points[i].frame >= p->nflex)
            return 0;
    for (i = 0; i < p->nloads; ++i)
        if (p->load_point[i] < 0 || p->load_point[i] >= p->npoints || !isfinite(p->load[3 * i])
            || !isfinite(p->load[3 * i + 1]) || !isfinite(p->load[3 * i + 2]))
            return 0;     /* each value: a sum of finite loads may overflow */
    for (i = 0; i < p->noutputs; ++i)
        if (p->outputs[i] < 0 || p->outputs[i] >= p->npoints)
            return 0;
    for (i = 0; i < p->ntendons; ++i) {
        if (p->route_start[i] < 0 || p->route_len[i] < 0 || !isfinite(p->tension[i]))
            return 0;
        for (j = 0; j < p->route_len[i]; ++j) {
            int r = p->route[p->route_start[i] + j];
            if (r < 0 || r >= p->npoints)
                return 0;
        }
    }
    return 1;
}

/* ... and the answer buffers fg_solve fills are there */
static int well_formed(const fg_problem *p, const fg_answer *out)
{
    return out != NULL && (p->ndof <= 0 || out->q != NULL)
           && (p->noutputs <= 0 || (out->pose != NULL && out->compliance != NULL))
           && problem_well_formed(p);
}

/* K at lam = 0 is the diagonal elastic stiffness (at_lambda: 0 S + diag): positive definite
 * exactly when its diagonal is positive, no factorization needed */
static int diagonal_positive(const fg_real *K, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        if (!(K[(size_t)i * (size_t)n + i] > 0.0))
            return 0;
    return 1;
}

static void clear_switched(fg_ws *w)
{
    memset(w->switched, 0, sizeof(int) * (size_t)FG_NFLEX(w->p));
}

/* relative rounding of a computed compliance (as the error estimate's ROUNDING_COMPLIANCE) */
#define FG_ELLIPSE_ROUNDING 1e-12

/* the compliance ellipse of a 2 x 2 compliance (chain_solver.h) */
FG_API void fg_ellipse(const fg_real *C, fg_real circle_tol, fg_real *out)
{
    fg_real a = C[0], b = 0.5 * (C[1] + C[2]), d = C[3], half, mean, major, minor, big;
    if (!isfinite(a + b + d)) {
        out[0] = out[1] = out[2] = NAN;
        return;
    }
    half = hypot(0.5 * (a - d), b);
    mean = 0.5 * (a + d);
    major = mean + half;
    /* the determinant over major, each product scaled first: a * d overflows where the
     * entries pass 1e154 (review: a minor axis NaN, null in the JSON, with no warning) */
    minor = major > 0.0 && mean > 0.0 ? (a / major) * d - (b / major) * b : mean - half;
    /* a rank-one compliance (one coordinate: prb, a link on one pin) has minor 0, which
     * rounding may put at -1e-17 or +8e-20: 0 within the compliance's rounding, so that
     * sqrt(minor) and a semi-axis drawn from it stay real and a rank-one answer reads as one
     * (an unstable state's truly negative minor is kept) */
    if (fabs(minor) <= FG_ELLIPSE_ROUNDING * major)
        minor = 0.0;
    big = fabs(major) > fabs(minor) ? fabs(major) : fabs(minor);
    out[0] = major;
    out[1] = minor;
    if (major - minor <= circle_tol * (big > FG_TINY ? big : FG_TINY)) {
        out[2] = 0.0;
    } else {
        out[2] = 0.5 * atan2(2.0 * b, a - d);
        if (out[2] <= -0.5 * FG_PI)
            out[2] += FG_PI;
    }
}

/* phi(sigma) of a kernel flexure with k coordinates q: phi = q_0 sigma + sum_m q_m B_m(sigma),
 * B_m = (P_{m+1}(x) - P_{m-1}(x)) / (2 (2m + 1)), x = 2 sigma - 1, the Legendre values by their
 * three-term recurrence in P (k + 1 entries): fg_answer.bend's value at a sample */
static fg_real legendre_phi(const fg_real *q, int k, fg_real sigma, fg_real *P)
{
    int m;
    fg_real x = 2.0 * sigma - 1.0, phi = q[0] * sigma;
    P[0] = 1.0;
    P[1] = x;
    for (m = 1; m < k; ++m)
        P[m + 1] = ((2.0 * m + 1.0) * x * P[m] - m * P[m - 1]) / (m + 1.0);
    for (m = 1; m < k; ++m)
        phi += q[m] * (P[m + 1] - P[m - 1]) / (2.0 * (2.0 * m + 1.0));
    return phi;
}

/* 1 if phi (legendre_phi) of a kernel flexure is strictly monotone on [0, 1] by a margin that
 * no rounding of legendre_phi can undo on a grid of step h: then, phi(0) being 0 (exactly, also
 * in floating point: P_m(-1) = (-1)^m), its largest |phi| on the grid is at sigma = 1, also as
 * computed. phi' = sum_m q_m P_m(2 sigma - 1) (B_m' = P_m), of degree k - 1 in sigma, lies between
 * the least and the largest of its Bernstein coefficients on [0, 1]; they are built mode by mode
 * (the shifted Legendre polynomial P_m has the Bernstein coefficients (-1)^(m+j) C(m, j); the sum
 * so far is degree-elevated by one before each). If they all have one sign and the smallest
 * magnitude b exceeds 1e4 eps S (2^k + 1/h), S = sum |q|, eps the machine epsilon, then |phi|
 * grows by at least h (b - e) from one sample to the next, e <= 32 eps 2^k S the coefficients'
 * rounding, about 100 times twice legendre_phi's rounding (a few ulps per recurrence step and
 * term: below 64 eps S for k <= 16). b: k entries of scratch. */
static int bend_monotone(const fg_real *q, int k, fg_real h, fg_real *b)
{
    int m, j;
    fg_real size = 0.0, low, binom, pow2 = 2.0;
    if (k > 16)
        return 0;
    for (m = 0; m < k; ++m) {
        size += fabs(q[m]);
        pow2 *= 2.0;
    }
    b[0] = q[0];
    for (m = 1; m < k; ++m) {
        b[m] = b[m - 1];                    /* degree elevation from m - 1 to m */
        for (j = m - 1; j >= 1; --j)
            b[j] = ((fg_real)j * b[j - 1] + (fg_real)(m - j) * b[j]) / (fg_real)m;
        binom = 1.0;                        /* C(m, j) */
        for (j = 0; j <= m; ++j) {
            b[j] += ((m + j) % 2 == 0 ? q[m] : -q[m]) * binom;
            binom = binom * (fg_real)(m - j) / (fg_real)(j + 1);
        }
    }
    low = 1e4 * FG_EPS * size * (pow2 + 1.0 / h);
    if (!(low <= FG_REAL_MAX))
        return 0;
    for (j = 0; j < k; ++j)
        if (!(b[j] > low))
            break;
    if (j == k)
        return 1;
    for (j = 0; j < k; ++j)
        if (!(b[j] < -low))
            return 0;
    return 1;
}

/* the largest |phi| near the sample sigma of a grid of step h whose largest |phi| is most
 * there: the vertex of the parabola through three samples about it (kept within [0, 1]: at
 * sigma = 1 the two before it), taken as the new middle of a grid a quarter as fine,
 * FG_BEND_REFINE times (the samples alone were up to 1.7e-4 rad short of the largest angle at
 * 65 samples, review, also where it lies between the last two; each refinement divides that
 * error by about 16), the vertex kept within the stencil's span; never less than most */
static fg_real bend_refined(const fg_real *q, int k, fg_real sigma, fg_real h, fg_real most,
                            fg_real *P)
{
    int r;
    for (r = 0; r < FG_BEND_REFINE; ++r) {
        fg_real c = sigma < h ? h : sigma > 1.0 - h ? 1.0 - h : sigma;   /* the stencil's middle */
        fg_real lo = fabs(legendre_phi(q, k, c - h, P));
        fg_real mid = fabs(legendre_phi(q, k, c, P));
        fg_real hi = fabs(legendre_phi(q, k, c + h, P));
        fg_real curve = lo - 2.0 * mid + hi, shift;
        if (mid > most)
            most = mid;
        if (lo > most)
            most = lo;
        if (hi > most)
            most = hi;
        if (!(curve < 0.0))       /* no maximum between them (or NaN): the samples' value */
            break;
        shift = 0.5 * h * (lo - hi) / curve;
        if (shift > h)
            shift = h;
        if (shift < -h)
            shift = -h;
        sigma = c + shift;
        h *= 0.25;
    }
    {
        fg_real phi = fabs(legendre_phi(q, k, sigma, P));
        return phi > most ? phi : most;
    }
}

/* max |phi(s)| along flexure f at its coordinates q (rad, relative to its root frame), on
 * samples points s/L = 0 .. 1: for a kernel flexure phi = sum q_n B_n with
 * B_0 = s/L and B_n = (P_{n+1}(x) - P_{n-1}(x)) / (2 (2n + 1)), x = 2 s/L - 1 (the integral of
 * the shifted Legendre polynomial), the Legendre values by their three-term recurrence
 * (legendre_phi); for the n-element chain the joint angles q_0 + ... + q_k; for the
 * pseudo-rigid body |q_0|. Where phi is monotone by a margin (bend_monotone: a flexure bent one
 * way, the usual answer) the largest sample is the last one, evaluated alone: the same value,
 * bit for bit. scratch: 4 (k + 1). */
static fg_real flexure_bend(const fg_flexure *f, const fg_real *q, int samples, fg_real *scratch)
{
    int k = FG_FLEX_NDOF(f), i;
    fg_real most = 0.0;
    if (f->kind == FG_MODEL_KERNEL) {
        fg_real *P = scratch, *b = scratch + (k + 1);
        if (samples >= 2 && bend_monotone(q, k, (fg_real)1.0 / (fg_real)(samples - 1), b))
            return fabs(legendre_phi(q, k, 1.0, P));
        int at = 0;
        for (i = 0; i < samples; ++i) {
            fg_real sigma = samples > 1 ? (fg_real)i / (fg_real)(samples - 1) : 1.0;
            fg_real phi = fabs(legendre_phi(q, k, sigma, P));
            if (phi > most) {
                most = phi;
                at = i;
            }
        }
        if (samples >= 3 && at > 0)   /* (phi(0) = 0: the largest is never at the root) */
            most = bend_refined(q, k, (fg_real)at / (fg_real)(samples - 1),
                                (fg_real)1.0 / (fg_real)(samples - 1), most, P);
        return most;
    }
    if (f->kind == FG_MODEL_FEM) {
        fg_real phi = 0.0;
        for (i = 0; i < k; ++i) {
            phi += q[i];
            if (fabs(phi) > most)
                most = fabs(phi);
        }
        return most;
    }
    return fabs(q[0]);
}

/* the workspace bound for a solve of p, with what is fixed for it: the loads' force
 * magnitudes and which tip frames' rotations are read */
static void prepare(fg_ws *w, const fg_problem *p, fg_real *work, int *iwork)
{
    int i;
    bind(w, p, work, iwork);
    for (i = 0; i < FG_NLOADS(p); ++i)
        w->hf[i] = hypot(p->load[3 * i], p->load[3 * i + 1]);
    for (i = 0; i < FG_NFLEX(p); ++i)
        w->rotated[i] = 0;
    for (i = 0; i < FG_NFLEX(p); ++i)
        if (p->flex[i].parent >= 0)
            w->rotated[p->flex[i].parent] = 1;
    for (i = 0; i < FG_NPOINTS(p); ++i)
        if (p->points[i].frame >= 0 && (p->points[i].x != 0.0 || p->points[i].y != 0.0))
            w->rotated[p->points[i].frame] = 1;
}

/* What the validity of an answer depends on, at the equilibrium (fg_answer.bend, kernel):
 * each flexure's largest bend and the kernel that evaluates it there. (The margin to a critical
 * load costs an eigen-decomposition, O(n^3): fg_margin, on request.) */
static void describe_answer(fg_ws *w, fg_answer *out)
{
    const fg_problem *p = w->p;
    int i;
    const fg_real *q = out->q;
    int known = out->kernel != NULL && at_kinematics(w, q);
    for (i = 0; i < FG_NFLEX(p); ++i) {
        const fg_flexure *f = &p->flex[i];
        const fg_real *qf = q + f->offset;
        if (out->bend != NULL)
            out->bend[i] = flexure_bend(f, qf, p->settings.bend_samples, w->scratch);
        if (out->kernel != NULL) {
            int state = FG_KERNEL_NONE;
            if (f->kind == FG_MODEL_KERNEL) {
                int first = first_kernel(w, i, q, known);   /* 0 for a Gauss-only flexure */
                if (first)
                    state = first;
                else if (f->gauss != NULL)
                    state = f->gauss_in_range(qf) ? FG_KERNEL_GAUSS : FG_KERNEL_GAUSS_PAST;
                else
                    state = FG_KERNEL_POLY_PAST;
            }
            out->kernel[i] = state;
        }
    }
}

static int margin_above(fg_ws *w, const fg_real *K, fg_real margin);

/* fg_answer.calm of an answer describe_answer has described: no validity warning can apply
 * (fg_problem.bend_limit, near_margin); 0 when the screen or what it reads was not asked for */
static int screen_calm(fg_ws *w, const fg_answer *out)
{
    const fg_problem *p = w->p;
    int i;
    if (p->bend_limit == NULL || out->bend == NULL || out->kernel == NULL
        || out->stiffness == NULL)
        return 0;
    for (i = 0; i < FG_NFLEX(p); ++i) {
        int k = out->kernel[i];
        if (!(out->bend[i] <= p->bend_limit[i]))   /* also a NaN */
            return 0;
        if (k != FG_KERNEL_NONE && k != FG_KERNEL_LOCAL && k != FG_KERNEL_POLY
            && k != FG_KERNEL_GAUSS)
            return 0;
    }
    return !out->stable || margin_above(w, out->stiffness, p->near_margin);
}

/* The eigenvalues of the symmetric A (n x n, upper triangle) in ev, ascending, without
 * eigenvectors: Householder reduction to tridiagonal form, then the implicit QL method (the
 * eigenvalues-only paths of Numerical Recipes' tred2 and tqli); scratch: n n + n. 0 if QL did
 * not converge (the caller uses the Jacobi method). For a few coordinates over twice as fast
 * as the Jacobi method with eigenvectors (measured through Python: 6 coordinates, 1.2 vs 2.9 us
 * per fg_margin call). */
static int eigenvalues_builtin(const fg_real *A, int n, fg_real *ev, fg_real *scratch)
{
    fg_real *z = scratch, *e = scratch + (size_t)n * (size_t)n, *d = ev;
    int i, j, k, l, m;
#define Z(r, c) z[(size_t)(r) * (size_t)n + (c)]
    for (i = 0; i < n; ++i)          /* the lower triangle, which tred2 reads */
        for (j = 0; j <= i; ++j)
            Z(i, j) = A[(size_t)j * (size_t)n + i];
    for (i = n - 1; i > 0; --i) {    /* tred2 */
        fg_real h = 0.0, scale = 0.0;
        l = i - 1;
        if (l > 0) {
            for (k = 0; k < i; ++k)
                scale += fabs(Z(i, k));
            if (scale == 0.0) {
                e[i] = Z(i, l);
            } else {
                fg_real f, g, hh;
                for (k = 0; k < i; ++k) {
                    Z(i, k) /= scale;
                    h += Z(i, k) * Z(i, k);
                }
                f = Z(i, l);
                g = f >= 0.0 ? -sqrt(h) : sqrt(h);
                e[i] = scale * g;
                h -= f * g;
                Z(i, l) = f - g;
                f = 0.0;
                for (j = 0; j < i; ++j) {
                    g = 0.0;
                    for (k = 0; k <= j; ++k)
                        g += Z(j, k) * Z(i, k);
                    for (k = j + 1; k < i; ++k)
                        g += Z(k, j) * Z(i, k);
                    e[j] = g / h;
                    f += e[j] * Z(i, j);
                }
                hh = f / (h + h);
                for (j = 0; j < i; ++j) {
                    f = Z(i, j);
                    e[j] = g = e[j] - hh * f;
                    for (k = 0; k <= j; ++k)
                        Z(j, k) -= f * e[k] + g * Z(i, k);
                }
            }
        } else {
            e[i] = Z(i, l);
        }
    }
    for (i = 0; i < n; ++i)
        d[i] = Z(i, i);
#undef Z
    for (i = 1; i < n; ++i)          /* tqli: e[i] couples d[i] and d[i + 1] */
        e[i - 1] = e[i];
    if (n > 0)
        e[n - 1] = 0.0;
    for (l = 0; l < n; ++l) {
        int iter = 0;
        do {
            for (m = l; m < n - 1; ++m) {
                fg_real dd = fabs(d[m]) + fabs(d[m + 1]);
                if (fabs(e[m]) <= FG_EPS * dd)
                    break;
            }
            if (m != l) {
                fg_real g, r, s, c, p, f, b;
                if (iter++ == 60)
                    return 0;
                g = (d[l + 1] - d[l]) / (2.0 * e[l]);
                r = sqrt(g * g + 1.0);
                g = d[m] - d[l] + e[l] / (g + (g >= 0.0 ? r : -r));
                s = c = 1.0;
                p = 0.0;
                for (i = m - 1; i >= l; --i) {
                    f = s * e[i];
                    b = c * e[i];
                    e[i + 1] = (r = sqrt(f * f + g * g));   /* (hypot: 3x the time; A is scaled to ~1) */
                    if (r == 0.0) {
                        d[i + 1] -= p;
                        e[m] = 0.0;
                        break;
                    }
                    s = f / r;
                    c = g / r;
                    g = d[i + 1] - p;
                    r = (d[i] - g) * s + 2.0 * c * b;
                    d[i + 1] = g + (p = s * r);
                    g = c * r - b;
                }
                if (r == 0.0 && i >= l)
                    continue;
                d[l] -= p;
                e[l] = g;
                e[m] = 0.0;
            }
        } while (m != l);
    }
    for (i = 1; i < n; ++i) {        /* ascending (insertion: n is small) */
        fg_real v = d[i];
        for (j = i - 1; j >= 0 && d[j] > v; --j)
            d[j + 1] = d[j];
        d[j + 1] = v;
    }
    for (i = 0; i < n; ++i)
        if (!isfinite(d[i]))
            return 0;
    return 1;
}

/* A = diag(v) K diag(v), upper triangles (fg_margin: v = D^-1/2) */
static void scale_by(fg_real *A, const fg_real *K, const fg_real *v, int n)
{
    int i, j;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j)
            A[(size_t)i * (size_t)n + j] = K[(size_t)i * (size_t)n + j] * v[i] * v[j];
}

FG_API fg_real fg_margin(const fg_problem *p, const fg_real *K, fg_real *work, int *iwork)
{
    fg_ws ws, *w = &ws;
    int n = FG_NDOF(p), i;
    fg_real *A;
    for (i = 0; i < n; ++i)
        if (!(p->stiffness[i] > 0.0))
            return NAN;
    if (n == 0)
        return 1.0;
    bind(w, p, work, iwork);
    A = w->lc;
    for (i = 0; i < n; ++i)
        w->vec1[i] = 1.0 / sqrt(p->stiffness[i]);
    scale_by(A, K, w->vec1, n);
#ifndef FG_SINGLE   /* LAPACK takes doubles */
    if (p->lapack.syev != NULL && n >= p->settings.lapack_min_size) {
        /* eigenvalues only: LAPACK skips the eigenvectors (a third of the work or less) */
        char jobz = 'N', uplo = 'L';
        int info = 0, lda = n, lwork = FG_LWORK(n);
        p->lapack.syev(&jobz, &uplo, &n, A, &lda, w->ew, w->ework, &lwork, &info);
        if (info == 0)
            return w->ew[0];
        scale_by(A, K, w->vec1, n);   /* dsyev failed and overwrote A: scale K again */
    }
#endif
    if (eigenvalues_builtin(A, n, w->ew, w->ework))
        return w->ew[0];
    return min_eig(w, A);
}

/* fg_margin_above in a bound workspace (its la and lc are overwritten) */
static int margin_above(fg_ws *w, const fg_real *K, fg_real margin)
{
    const fg_problem *p = w->p;
    int n = FG_NDOF(p), i;
    fg_real *A;
    for (i = 0; i < n; ++i)
        if (!(p->stiffness[i] > 0.0))
            return 0;
    if (n == 0)
        return 1.0 > margin;
    A = w->lc;
    for (i = 0; i < n; ++i) {   /* K - margin D, upper triangle: positive definite iff every
                                 * generalized eigenvalue of (K, D) exceeds margin */
        memcpy(A + (size_t)i * (size_t)n + i, K + (size_t)i * (size_t)n + i,
               sizeof(fg_real) * (size_t)(n - i));
        A[(size_t)i * (size_t)n + i] -= margin * p->stiffness[i];
    }
    return cholesky(w, A, w->la);
}

FG_API int fg_margin_above(const fg_problem *p, const fg_real *K, fg_real margin, fg_real *work,
                           int *iwork)
{
    fg_ws ws;
    bind(&ws, p, work, iwork);
    return margin_above(&ws, K, margin);
}

FG_API int fg_calm(const fg_problem *p, const fg_answer *out, fg_real *work, int *iwork)
{
    fg_ws ws;
    bind(&ws, p, work, iwork);
    return screen_calm(&ws, out);
}

FG_API int fg_flexure_tip(const fg_flexure *f, const fg_real *q, fg_real *pose, fg_real *J, fg_real *H,
                   fg_real *scratch)
{
    int switched = 0, used, computed = 0;
    return flexure_tip(f, q, pose, J, H, scratch, &switched, -1, &used, &computed);
}

/* ---- the error estimate: one Newton step of a richer model from an answer ---------------- */

/* ||A||_2 of the symmetric 2 x 2 [[a, b], [b, c]]: its largest |eigenvalue| */
static fg_real sym2_norm(fg_real a, fg_real b, fg_real c)
{
    return fabs(0.5 * (a + c)) + hypot(0.5 * (a - c), b);
}

/* ||A||_2 of the symmetric 3 x 3 A (its upper triangle, row-major): its largest |eigenvalue|,
 * from the closed form of the three (the trigonometric solution of the characteristic cubic) */
static fg_real sym3_norm(const fg_real *A)
{
    fg_real off = A[1] * A[1] + A[2] * A[2] + A[5] * A[5], m = (A[0] + A[4] + A[8]) / 3.0;
    fg_real d0 = A[0] - m, d1 = A[4] - m, d2 = A[8] - m, p, r, phi, hi, lo;
    p = sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off) / 6.0);
    if (!(p > 0.0))
        return fabs(m);
    /* det((A - m I) / p) / 2, clamped: rounding may put it just outside [-1, 1] */
    r = (d0 * (d1 * d2 - A[5] * A[5]) - A[1] * (A[1] * d2 - A[5] * A[2])
         + A[2] * (A[1] * A[5] - d1 * A[2])) / (2.0 * p * p * p);
    r = r < -1.0 ? -1.0 : r > 1.0 ? 1.0 : r;
    phi = acos(r) / 3.0;
    hi = m + 2.0 * p * cos(phi);
    lo = m + 2.0 * p * cos(phi + 2.0 * FG_PI / 3.0);
    return fabs(hi) > fabs(lo) ? fabs(hi) : fabs(lo);
}

/* The differences of an answer (pose, compliance per output) to the richer model at state st,
 * whose stiffness's Cholesky factor is in w->la, linearized along -d (st's q minus d is the
 * richer model's equilibrium to first order; d NULL: st is taken as it): out[2 j] =
 * max(|r_j - r_j,rich| / scale[j], |angle_j - angle_j,rich|), out[2 j + 1] = the larger of
 * ||C_j - C_j,rich||_2 / ||C_j,rich||_2 for the 2 x 2 position compliances and for the 3 x 3
 * compliances d(x, y, angle)/d(fx, fy, moment) with the angle row and column times scale[j]
 * (D C D, D = diag(1, 1, scale[j]): every entry then in the units of the position block, so
 * one norm weighs the rotational compliance as the positional one; a hinge's rotational
 * compliance is what many designs read). 0 if one is not finite. */
static int estimate_differences(fg_ws *w, const fg_state *st, const fg_real *d,
                                const fg_real *pose, const fg_real *compliance,
                                const fg_real *scale, fg_real *out)
{
    const fg_problem *p = w->p;
    int n = FG_N(w), j, a;
    for (j = 0; j < FG_NOUTPUTS(p); ++j) {
        const fg_real *o = st->out + (size_t)j * (3 + 3 * (size_t)n), *J = o + 3;
        const fg_real *P = pose + 3 * j, *C = compliance + 9 * j;
        fg_real R[3], Cr[9], Sr[9], Sd[9], dpos, dth, nr, nd, rel2, rel3;
        fg_real *col = w->lc, sc[3];
        int b;
        for (a = 0; a < 3; ++a) {
            R[a] = o[a];
            if (d != NULL)
                R[a] -= dot(J + (size_t)a * (size_t)n, d, n);
        }
        /* C_rich = J K^-1 J^T = Y^T Y with Y = U^-T J^T (K = U^T U): its upper triangle */
        for (a = 0; a < 3; ++a)
            cholesky_forward(w, w->la, J + (size_t)a * (size_t)n, col + (size_t)a * (size_t)n);
        for (a = 0; a < 3; ++a)
            for (b = a; b < 3; ++b)
                Cr[3 * a + b] = dot(col + (size_t)a * (size_t)n, col + (size_t)b * (size_t)n, n);
        dpos = hypot(P[0] - R[0], P[1] - R[1]) / scale[j];
        dth = fabs(remainder(P[2] - R[2], 2.0 * FG_PI));
        nr = sym2_norm(Cr[0], Cr[1], Cr[4]);
        nd = sym2_norm(C[0] - Cr[0], 0.5 * (C[1] + C[3]) - Cr[1], C[4] - Cr[4]);
        rel2 = nr > 0.0 ? nd / nr : nd;
        sc[0] = sc[1] = 1.0;
        sc[2] = scale[j];
        for (a = 0; a < 3; ++a)
            for (b = a; b < 3; ++b) {
                fg_real s2 = sc[a] * sc[b];
                Sr[3 * a + b] = s2 * Cr[3 * a + b];
                Sd[3 * a + b] = s2 * (0.5 * (C[3 * a + b] + C[3 * b + a]) - Cr[3 * a + b]);
            }
        nr = sym3_norm(Sr);
        nd = sym3_norm(Sd);
        rel3 = nr > 0.0 ? nd / nr : nd;
        out[2 * j] = dpos > dth ? dpos : dth;
        out[2 * j + 1] = rel2 > rel3 ? rel2 : rel3;
        if (!isfinite(dpos) || !isfinite(dth) || !isfinite(rel2) || !isfinite(rel3))
            return 0;
    }
    return 1;
}

/* the differences in out (estimate_differences) made estimates: factor times each, plus its
 * floor (floors); the largest after them (FG_ESTIMATED: every one finite and >= 0) */
static void estimate_margins(int m, const fg_real *floors, fg_real factor, fg_real *out)
{
    fg_real total = 0.0;
    int j;
    for (j = 0; j < m; ++j) {
        out[2 * j] = factor * out[2 * j] + floors[j];
        out[2 * j + 1] = factor * out[2 * j + 1] + floors[m];
        if (out[2 * j] > total)
            total = out[2 * j];
        if (out[2 * j + 1] > total)
            total = out[2 * j + 1];
    }
    out[2 * m] = total;
}

FG_API int fg_estimate(const fg_problem *rich, const fg_real *T, int nbase, const fg_real *q,
                       const fg_real *pose, const fg_real *compliance, const fg_real *scale,
                       const fg_real *floors, fg_real factor, fg_real reach, fg_real *work,
                       int *iwork, fg_real *out)
{
    fg_ws ws, *w = &ws;
    fg_state *st, *prev, *swap;
    fg_real *q0, *d, *dprev, *tmp, last, first = 0.0;
    int n, i, k;
    if (rich == NULL || !problem_well_formed(rich) || nbase < 0 || (nbase > 0 && q == NULL)
        || !(reach > 0.0) || !(factor > 0.0) || floors == NULL || out == NULL
        || (rich->ndof > 0 && T == NULL)
        || (rich->noutputs > 0 && (pose == NULL || compliance == NULL || scale == NULL)))
        return FG_ESTIMATE_MALFORMED;
    n = rich->ndof;
    prepare(w, rich, work, iwork);
    clear_switched(w);
    st = &w->st[0];
    prev = &w->st[1];
    q0 = w->qplus;       /* (evaluate uses vec1, vec2 for tendons) */
    d = w->qminus;
    dprev = w->t0;
    for (i = 0; i < n; ++i) {        /* q mapped to the richer model's coordinates */
        const fg_real *Ti = T + (size_t)i * (size_t)nbase;
        fg_real sum = 0.0;
        for (k = 0; k < nbase; ++k)
            sum += Ti[k] * q[k];
        q0[i] = sum;
    }
    if (!evaluate(w, q0, 1.0, st))
        return FG_ESTIMATE_NO_EVALUATION;
    /* plain Newton from T q: every state's stiffness factored (positive definite, else the
     * caller solves), its step d. The answer's difference to the richer equilibrium is that of
     * the first state where Newton is seen to converge (an equilibrium to the solver's tol, T q
     * itself included, or a step at most FG_ESTIMATE_CONTRACTION of the one before), along the
     * last step linearized;
     * the compliance is taken at that state. Not converging within max_iterations steps and
     * reach of T q: FG_ESTIMATE_FAR. */
    last = 0.0;
    for (k = 0;; ++k) {
        fg_real step;
        if (!cholesky(w, st->K, w->la))
            return FG_ESTIMATE_UNSTABLE;
        cholesky_solve(w, w->la, st->r, d);
        step = norm_inf(d, n);
        if (k == 0)
            first = step;
        /* converged: an equilibrium, or a step a CONTRACTION of the one before and a
         * CONTRACTION^3 of the first (from a coarse answer, 0.5 to 1 away, the second step
         * is still too long for the compliance taken there: measured 40 % off; the third,
         * at a hundredth of the first, 7 % short on prb's cantilever at 8 EI/L^2; from an
         * accurate answer the first step after T q is far below either) */
        if (st->rel <= rich->settings.tol
            || (k > 0 && step <= FG_ESTIMATE_CONTRACTION * last
                && step <= FG_ESTIMATE_CONTRACTION * FG_ESTIMATE_CONTRACTION
                                  * FG_ESTIMATE_CONTRACTION * first))
            break;
        if (k == rich->settings.max_iterations)
            return FG_ESTIMATE_FAR;
        for (i = 0; i < n; ++i) {
            w->t1[i] = st->q[i] - d[i];
            w->vec4[i] = w->t1[i] - q0[i];
        }
        if (!(norm_inf(w->vec4, n) <= reach))
            return FG_ESTIMATE_FAR;
        swap = prev;
        prev = st;
        st = swap;
        tmp = dprev;
        dprev = d;
        d = tmp;
        last = step;
        if (!evaluate(w, w->t1, 1.0, st))
            return FG_ESTIMATE_NO_EVALUATION;
    }
    if (!estimate_differences(w, st, d, pose, compliance, scale, out))
        return FG_ESTIMATE_UNDEFINED;
    estimate_margins(rich->noutputs, floors, factor, out);
    for (i = 0; i < n; ++i)       /* the richer equilibrium: the last step taken, linearized */
        out[2 * rich->noutputs + 1 + i] = st->q[i] - d[i];
    return FG_ESTIMATED;
}

/* Solve: the warm start, else the unloaded state, the direct solve, else the continuation;
 * always to an answer (FG_SOLVED) or to the reason there is none (FG_NO_EQUILIBRIUM:
 * out->failure, last_error*, model_error*). */
FG_API int fg_solve(const fg_problem *p, fg_real *work, int *iwork, fg_answer *out)
{
    fg_ws ws, *w = &ws;
    fg_state *st0, *cur, *spare, *smp;
    fg_real *factor = NULL;
    int n, i, j, iterations = 0, status;

    if (p == NULL || !well_formed(p, out))
        return FG_MODEL_ERROR;
    n = FG_NDOF(p);
    prepare(w, p, work, iwork);
    st0 = &w->st[0];
    cur = &w->st[1];
    spare = &w->st[2];
    smp = &w->st[3];
    out->iterations = 0;
    out->stable = 0;
    out->ncritical = 0;
    out->failure = FG_FAIL_NONE;
    out->failure_load_factor = 0.0;
    out->warm = 0;
    out->calm = 0;

    clear_switched(w);
    if (p->q0 != NULL) {
        /* warm start: Newton at the full load from q0, accepted if it converges to a stable
         * equilibrium within max_dq of q0 and, with settings.warm_on_path, that equilibrium
         * is on the load path from the unloaded state (on_load_path, the direct solve's check:
         * where several stable equilibria hold the load, q0 may lie nearer another than the
         * one the load path reaches, as a previous answer at other loads can); else (its
         * iterations counted) the solve from the unloaded state, the model error cleared */
        int warm = evaluate(w, p->q0, 1.0, cur)
                   && newton(w, &cur, &spare, NULL, p->settings.max_iterations, 0, &iterations)
                   && end_factor_of(w, cur);
        if (warm) {
            for (i = 0; i < n; ++i)
                w->vec4[i] = cur->q[i] - p->q0[i];
            warm = angle_change(w, w->vec4) <= p->settings.max_dq;
        }
        if (warm && p->settings.warm_on_path) {
            fg_errors saved;      /* the samples are no part of the answer: flags as before */
            save_trial(w, &saved);
            memset(w->vec1, 0, sizeof(fg_real) * (size_t)n);
            warm = evaluate(w, w->vec1, 0.0, st0) && diagonal_positive(st0->K, n)
                   && on_load_path(w, st0, cur, smp, 0);
            restore_trial(w, &saved);
        }
        if (warm) {
            factor = w->lb;
            out->warm = 1;
            goto answer;
        }
        clear_model_error(w);
        clear_switched(w);        /* the rejected attempt's kernel switches are not the path's */
        cur = &w->st[1];
        spare = &w->st[2];
    }
    /* the unloaded state (q = 0, lam = 0: an equilibrium, when it can be evaluated), then the
     * full load at once, else the continuation from it */
    memset(w->vec1, 0, sizeof(fg_real) * (size_t)n);
    if (!evaluate(w, w->vec1, 0.0, st0)) {
        out->failure = FG_FAIL_UNLOADED;
        out->failure_load_factor = 0.0;
        goto failed;
    }
    {
        int it0 = iterations;
        if (p->settings.max_steps >= 1 && diagonal_positive(st0->K, n)
            && direct_solve(w, st0, &cur, &spare, smp, &iterations)) {
            factor = w->lb;
        } else {
            iterations = it0;     /* a rejected direct attempt leaves no trace */
            cur = continuation(w, st0, &iterations, out);
            if (cur == NULL)
                goto failed;
            spare = free_state(w, cur, NULL, NULL, NULL);
        }
    }
answer:
    status = finish(w, cur, spare, factor, iterations, out);
    describe_answer(w, out);
    out->calm = status == FG_SOLVED && screen_calm(w, out);
    if (out->switched != NULL)
        for (j = 0; j < FG_NFLEX(p); ++j)
            out->switched[j] = w->switched[j];
    goto report;
failed:
    status = FG_NO_EQUILIBRIUM;
    out->iterations = iterations;
    if (out->switched != NULL)
        for (j = 0; j < FG_NFLEX(p); ++j)
            out->switched[j] = w->switched[j];
report:
    out->last_error = w->err;
    out->last_error_load_factor = w->err_lam;
    out->last_error_residual = w->err_rel;
    out->last_error_iterations = w->err_iterations;
    out->last_error_flexure = w->err_flex;
    out->last_error_route = w->err_route;
    out->model_error = w->merr;
    out->model_error_flexure = w->merr_flex;
    out->model_error_route = w->merr_route;
    out->evaluations = w->evaluations;
    return status;
}
