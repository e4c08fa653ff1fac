/* The compiled chain solver: equilibrium and compliance of a scene in one call.
 *
 * The same mathematics and the same algorithm as flexgen/chain.py and flexgen/equilibrium.py
 * (read their docstrings first), step for step: the full load in one Newton solve from the
 * unloaded state when every check of equilibrium._direct_solve passes (direct_solve), else the
 * load continuation (continuation), or a warm start from a given q0; then polishing and the
 * compliance of the output points (finish). The continuation handles a loss of stability as
 * the Python solver does: a step from a stable onto an unstable state is a bifurcation (such as
 * Euler buckling: located by regula falsi on the smallest eigenvalue, then the stable side taken
 * by descent, cross_bifurcation) or else overshoots a limit point (a shorter step); where the
 * path ends the solve descends to the equilibrium it snaps to. Each such critical load factor is
 * reported in fg_answer.critical with its kind (the Python side rebuilds the Python solver's
 * warnings from them), and so is every flexure whose "auto" model switched to its Gauss kernel
 * (fg_answer.switched). Where the Python solver would do more than that -- a warm start fails,
 * the critical array is full, no equilibrium is found -- fg_solve returns FG_FALLBACK and the
 * Python solver runs the scene. So the two give the same answers (tests/test_compiled.py).
 *
 * Flexure models: the generated smooth curvature kernels (scm{N}, scm{N}_gauss{G}: function
 * pointers, so this file needs no header of theirs), the n-element chain ("fem", the same
 * discretisation as flexgen/models/fem.py) and the pseudo-rigid body (flexgen/models/prb.py).
 * Every elastic energy is quadratic with a diagonal Hessian (``stiffness``).
 *
 * Linear algebra: built-in Cholesky, LU and (cyclic Jacobi) symmetric eigen-decomposition, or
 * LAPACK's dpotrf/dpotrs, dgetrf/dgetrs and dsyev by function pointer (fg_lapack) from
 * lapack.min_size coordinates on.
 *
 * C99, no heap, no globals: the caller provides the workspace (fg_work_size doubles and
 * fg_iwork_size ints). Compiled with gcc -std=c99 -Wall -Wextra -Werror -pedantic.
 */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "chain_solver.h"

/* ---- workspace ------------------------------------------------------------------------- */

#define FG_NSTATES 6        /* states held at once (the bifurcation crossing needs five) */
#define FG_LWORK(n) (34 * (n) + 1)   /* dsyev's work: enough for its blocked reduction */

typedef struct {
    double *q, *gU, *QL, *QT, *S;   /* load-independent parts (S: load Hessian at lam = 1) */
    double *r, *K, *Q;              /* at the state's load factor */
    double U, W, V, gmax, rmax, Pi, scale, rel, lam;
} fg_state;

typedef struct {
    const fg_problem *p;
    int n;
    /* kinematics at the last evaluated q */
    double *fpose, *fJ;     /* per flexure tip frame: pose (3), J (3 x n) */
    double *fdata;          /* per flexure: moving_parent, awx, awy, c, s, wx, wy, moving */
    double *tpose, *tJ, *tH, *RJ;   /* per flexure tip kinematics (root frame), R dv rows */
    double *ppose, *pJ;     /* per point: pose (3), J (3 x n) */
    double *acc;            /* per flexure: hessian_sum accumulators (4) */
    double *scratch;        /* fem tip: 4 (kmax + 1) */
    double *reach;          /* n */
    double *la, *lb, *lc;   /* n x n linear algebra scratch, n-vectors */
    double *vec1, *vec2, *vec3, *vec4, *t0, *t1;   /* n-vectors */
    double *vmin, *cvec, *qplus, *qminus;          /* n-vectors (stability, descent) */
    double *ew, *eV, *ework;    /* eigenvalues (n), eigenvectors (n x n, one a row), scratch */
    int *piv;
    int *switched;          /* per flexure: an "auto" flexure used its Gauss kernel since the
                             * flags were last cleared (SCMModel.switched) */
    fg_state st[FG_NSTATES];
} fg_ws;

static size_t tip_size(const fg_problem *p)
{
    size_t s = 0;
    int i;
    for (i = 0; i < p->nflex; ++i) {
        size_t k = (size_t)p->flex[i].ndof;
        s += 3 + 3 * k + 3 * k * k + 2 * k;
    }
    return s;
}

static int kmax(const fg_problem *p)
{
    int i, m = 0;
    for (i = 0; i < p->nflex; ++i)
        if (p->flex[i].ndof > m)
            m = p->flex[i].ndof;
    return m;
}

size_t fg_work_size(const fg_problem *p)
{
    size_t n = (size_t)p->ndof, F = (size_t)p->nflex, P = (size_t)p->npoints;
    size_t state = 6 * n + 2 * n * n;
    return F * (3 + 3 * n) + 8 * F + tip_size(p) + P * (3 + 3 * n) + 4 * F
        + 4 * ((size_t)kmax(p) + 1) + n + 3 * n * n + 10 * n
        + n + n * n + 2 * n * n + FG_LWORK(n) + FG_NSTATES * state + 16;
}

size_t fg_iwork_size(const fg_problem *p)
{
    return (size_t)p->ndof + 1 + (size_t)p->nflex;    /* pivots, kernel-switch flags */
}

static void bind(fg_ws *w, const fg_problem *p, double *work, int *iwork)
{
    size_t n = (size_t)p->ndof, F = (size_t)p->nflex, P = (size_t)p->npoints;
    double *x = work;
    int i;
    w->p = p;
    w->n = p->ndof;
    w->fpose = x; x += 3 * F;
    w->fJ = x; x += 3 * n * F;
    w->fdata = x; x += 8 * F;
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
    w->lc = x; x += n * n;
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
    w->ew = x; x += n;
    w->eV = x; x += n * n;
    w->ework = x; x += 2 * n * n + FG_LWORK(n);
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
    }
    w->piv = iwork;
    w->switched = iwork + p->ndof + 1;
}

/* the tip block of flexure i: J (3 k), H (3 k k), RJ (2 k), after the F tip poses */
static double *tip_block(const fg_ws *w, int i)
{
    double *x = w->tJ;
    int j;
    for (j = 0; j < i; ++j) {
        size_t k = (size_t)w->p->flex[j].ndof;
        x += 3 * k + 3 * k * k + 2 * k;
    }
    return x;
}

/* ---- flexure models ------------------------------------------------------------------------ */

/* pose (3), J (3 x k), H (3 x k x k) of the tip in the root frame, physical units; 0 if the
 * model cannot be evaluated at q (a polynomial-only kernel past its range) */
static int flexure_tip(const fg_flexure *f, const double *q, double *pose, double *J, double *H,
                       double *scratch, int *switched)
{
    int k = f->ndof, i, j;
    if (f->kind == FG_MODEL_KERNEL) {
        fg_kernel kernel;
        double L = f->length;
        if (f->poly != NULL && (f->gauss == NULL || f->in_range(q)))
            kernel = f->poly;
        else if (f->gauss != NULL) {
            kernel = f->gauss;
            if (f->poly != NULL)
                *switched = 1;
        } else
            return 0;
        if (f->poly != NULL && f->gauss == NULL && !f->in_range(q))
            return 0;
        kernel(q, pose, J, H);
        pose[0] *= L;
        pose[1] *= L;
        for (i = 0; i < 2 * k; ++i)
            J[i] *= L;
        for (i = 0; i < 2 * k * k; ++i)
            H[i] *= L;
        return 1;
    }
    if (f->kind == FG_MODEL_FEM) {
        /* segments h/2, h, ..., h, h/2; phi_k = q_0 + ... + q_{k-1} */
        double h = f->length / k;
        double *lc = scratch, *ls = scratch + (k + 1), *tc = scratch + 2 * (k + 1),
               *ts = scratch + 3 * (k + 1);
        double phi = 0.0, sc = 0.0, ss = 0.0;
        for (i = 0; i <= k; ++i) {
            double seg = (i == 0 || i == k) ? 0.5 * h : h;
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
        double a = q[0], r = f->gamma * f->length, c = cos(a), s = sin(a);
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

/* ---- kinematics (chain.py: _light_frames, _pj) ------------------------------------------- */

static int kinematics(fg_ws *w, const double *q)
{
    const fg_problem *p = w->p;
    int n = w->n, i, a, j;
    for (i = 0; i < p->nflex; ++i) {
        const fg_flexure *f = &p->flex[i];
        int k = f->ndof, off = f->offset;
        double *pose = w->fpose + 3 * i, *J = w->fJ + (size_t)3 * n * i, *d = w->fdata + 8 * i;
        double *tp = w->tpose + 3 * i, *blk = tip_block(w, i);
        double *tJ = blk, *tH = blk + 3 * k, *RJ = blk + 3 * k + 3 * k * k;
        double pp[3] = {0.0, 0.0, 0.0};
        const double *PJ = NULL;
        int moving = 0, tmoving = 0;
        double th, c, s, awx, awy, rp[3], wx, wy;
        if (f->parent >= 0) {
            memcpy(pp, w->fpose + 3 * f->parent, sizeof pp);
            PJ = w->fJ + (size_t)3 * n * f->parent;
            moving = w->fdata[8 * f->parent + 7] != 0.0;
        }
        th = pp[2];
        c = cos(th);
        s = sin(th);
        awx = c * f->at[0] - s * f->at[1];
        awy = s * f->at[0] + c * f->at[1];
        rp[0] = pp[0] + awx;
        rp[1] = pp[1] + awy;
        rp[2] = th + f->at[2];
        /* J = root J (parent J with the offset's rotation) */
        if (PJ != NULL)
            memcpy(J, PJ, sizeof(double) * 3 * (size_t)n);
        else
            memset(J, 0, sizeof(double) * 3 * (size_t)n);
        if (moving)
            for (j = 0; j < n; ++j) {
                J[j] -= awy * J[2 * n + j];
                J[n + j] += awx * J[2 * n + j];
            }
        if (!flexure_tip(f, q + off, tp, tJ, tH, w->scratch, &w->switched[i]))
            return 0;
        th = rp[2];
        c = cos(th);
        s = sin(th);
        wx = c * tp[0] - s * tp[1];
        wy = s * tp[0] + c * tp[1];
        pose[0] = rp[0] + wx;
        pose[1] = rp[1] + wy;
        pose[2] = th + tp[2];
        if (moving)
            for (j = 0; j < n; ++j) {
                J[j] -= wy * J[2 * n + j];
                J[n + j] += wx * J[2 * n + j];
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
    }
    for (i = 0; i < p->npoints; ++i) {
        const fg_point *pt = &p->points[i];
        double *pose = w->ppose + 3 * i, *J = w->pJ + (size_t)3 * n * i;
        if (pt->frame < 0) {
            pose[0] = pt->x;
            pose[1] = pt->y;
            pose[2] = 0.0;
            memset(J, 0, sizeof(double) * 3 * (size_t)n);
            continue;
        }
        {
            const double *fp = w->fpose + 3 * pt->frame, *FJ = w->fJ + (size_t)3 * n * pt->frame;
            double c = cos(fp[2]), s = sin(fp[2]);
            double wx = c * pt->x - s * pt->y, wy = s * pt->x + c * pt->y;
            pose[0] = fp[0] + wx;
            pose[1] = fp[1] + wy;
            pose[2] = fp[2];
            memcpy(J, FJ, sizeof(double) * 3 * (size_t)n);
            if (w->fdata[8 * pt->frame + 7] != 0.0)
                for (j = 0; j < n; ++j) {
                    J[j] -= wy * FJ[2 * n + j];
                    J[n + j] += wx * FJ[2 * n + j];
                }
        }
    }
    return 1;
}

/* G += sum_p c_p . H_p over the coefficients already in w->acc (chain.py: hessian_sum) */
static void add_coefficient(fg_ws *w, int point, double c0, double c1, double c2)
{
    const fg_point *pt = &w->p->points[point];
    double *a;
    if (pt->frame < 0 || (c0 == 0.0 && c1 == 0.0 && c2 == 0.0))
        return;
    a = w->acc + 4 * pt->frame;
    a[0] += c0;
    a[1] += c1;
    a[2] += c2;
    if (pt->x != 0.0 || pt->y != 0.0) {
        double th = w->fpose[3 * pt->frame + 2], c = cos(th), s = sin(th);
        double wx = c * pt->x - s * pt->y, wy = s * pt->x + c * pt->y;
        a[2] += c1 * wx - c0 * wy;
        a[3] += c0 * wx + c1 * wy;
    }
}

static void hessian_sum(fg_ws *w, double *G)
{
    const fg_problem *p = w->p;
    int n = w->n, i, a, b, j;
    for (i = p->nflex - 1; i >= 0; --i) {
        const fg_flexure *f = &p->flex[i];
        int k = f->ndof, off = f->offset;
        double *acc = w->acc + 4 * i, *d = w->fdata + 8 * i, *blk = tip_block(w, i);
        double *tH = blk + 3 * k, *RJ = blk + 3 * k + 3 * k * k;
        double c0 = acc[0], c1 = acc[1], c2 = acc[2], kk = acc[3];
        double c = d[3], s = d[4], e0, e1;
        if (kk != 0.0) {
            const double *Jth = w->fJ + (size_t)3 * n * i + 2 * (size_t)n;
            for (a = 0; a < n; ++a)
                for (b = 0; b < n; ++b)
                    G[a * n + b] -= kk * Jth[a] * Jth[b];
        }
        e0 = c * c0 + s * c1;
        e1 = c * c1 - s * c0;
        for (a = 0; a < k; ++a)
            for (b = 0; b < k; ++b)
                G[(off + a) * n + off + b] += e0 * tH[a * k + b] + e1 * tH[k * k + a * k + b]
                                              + c2 * tH[2 * k * k + a * k + b];
        if (f->parent < 0 || (c0 == 0.0 && c1 == 0.0 && c2 == 0.0))
            continue;
        {
            double wx = d[5], wy = d[6], awx = d[1], awy = d[2];
            double r2 = c2 + c1 * wx - c0 * wy, kr = c0 * wx + c1 * wy;
            double *pa = w->acc + 4 * f->parent;
            if (d[0] != 0.0) {   /* the parent frame moves: cross terms with its angle */
                const double *Jr = w->fJ + (size_t)3 * n * f->parent + 2 * (size_t)n;
                for (a = 0; a < k; ++a) {
                    double m = c1 * RJ[a] - c0 * RJ[k + a];
                    for (j = 0; j < n; ++j) {
                        G[(off + a) * n + j] += m * Jr[j];
                        G[j * n + off + a] += m * Jr[j];
                    }
                }
            }
            pa[0] += c0;
            pa[1] += c1;
            pa[2] += r2 + c1 * awx - c0 * awy;
            pa[3] += kr + c0 * awx + c1 * awy;
        }
    }
}

/* ---- the potential: parts at q, then the state at a load factor -------------------------- */

static int finite_all(const double *x, size_t m)
{
    size_t i;
    for (i = 0; i < m; ++i)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

static void at_lambda(const fg_ws *w, fg_state *st, double lam)
{
    const fg_problem *p = w->p;
    int n = w->n, i, j;
    double rn = 0.0;
    st->lam = lam;
    for (i = 0; i < n; ++i) {
        st->r[i] = st->gU[i] - lam * st->QL[i] + lam * st->QT[i];
        st->Q[i] = st->QL[i] - st->QT[i];
        if (fabs(st->r[i]) > rn)
            rn = fabs(st->r[i]);
    }
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            double kij = lam * st->S[i * n + j], kji = lam * st->S[j * n + i];
            if (i == j) {
                kij += p->stiffness[i];
                kji += p->stiffness[i];
            }
            st->K[i * n + j] = 0.5 * (kij + kji);
        }
    st->Pi = st->U - lam * st->W + lam * st->V;
    st->scale = st->gmax > fabs(lam) * st->rmax ? st->gmax : fabs(lam) * st->rmax;
    if (rn == 0.0)
        st->rel = 0.0;
    else
        st->rel = st->scale > 0.0 ? rn / st->scale : INFINITY;
}

/* the state at (q, lam); 0 if a model cannot be evaluated or a value is not finite */
static int evaluate(fg_ws *w, const double *q, double lam, fg_state *st)
{
    const fg_problem *p = w->p;
    int n = w->n, i, j, t, a, b;
    if (st->q != q)
        memcpy(st->q, q, sizeof(double) * (size_t)n);
    if (!kinematics(w, st->q))
        return 0;
    st->U = 0.0;
    st->gmax = 0.0;
    for (i = 0; i < n; ++i) {
        st->U += 0.5 * p->stiffness[i] * st->q[i] * st->q[i];
        st->gU[i] = p->stiffness[i] * st->q[i];
        if (fabs(st->gU[i]) > st->gmax)
            st->gmax = fabs(st->gU[i]);
        st->QL[i] = st->QT[i] = w->reach[i] = 0.0;
    }
    memset(st->S, 0, sizeof(double) * (size_t)n * (size_t)n);
    memset(w->acc, 0, sizeof(double) * 4 * (size_t)p->nflex);
    st->W = st->V = 0.0;
    for (t = 0; t < p->nloads; ++t) {
        int pt = p->load_point[t];
        const double *F = p->load + 3 * t;
        const double *pose = w->ppose + 3 * pt, *J = w->pJ + (size_t)3 * n * pt;
        double hf = hypot(F[0], F[1]), mf = fabs(F[2]);
        st->W += F[0] * pose[0] + F[1] * pose[1] + F[2] * pose[2];
        for (i = 0; i < n; ++i) {
            st->QL[i] += F[0] * J[i] + F[1] * J[n + i] + F[2] * J[2 * n + i];
            w->reach[i] += hf * sqrt(J[i] * J[i] + J[n + i] * J[n + i]) + mf * fabs(J[2 * n + i]);
        }
        add_coefficient(w, pt, -F[0], -F[1], -F[2]);
    }
    for (t = 0; t < p->ntendons; ++t) {
        double T = p->tension[t], l = 0.0;
        const int *route = p->route + p->route_start[t];
        double *gl = w->vec1, *m = w->vec2;
        if (T == 0.0)
            continue;
        memset(gl, 0, sizeof(double) * (size_t)n);
        for (j = 0; j + 1 < p->route_len[t]; ++j) {
            int pa = route[j], pb = route[j + 1];
            const double *A = w->ppose + 3 * pa, *B = w->ppose + 3 * pb;
            const double *JA = w->pJ + (size_t)3 * n * pa, *JB = w->pJ + (size_t)3 * n * pb;
            double dx = B[0] - A[0], dy = B[1] - A[1], rho = hypot(dx, dy), ux, uy;
            if (rho == 0.0)
                return 0;
            ux = dx / rho;
            uy = dy / rho;
            l += rho;
            for (i = 0; i < n; ++i) {
                double Jx = JB[i] - JA[i], Jy = JB[n + i] - JA[n + i];
                gl[i] += ux * Jx + uy * Jy;
                m[i] = ux * Jy - uy * Jx;
                w->reach[i] += fabs(T) * sqrt(Jx * Jx + Jy * Jy);
            }
            for (a = 0; a < n; ++a)       /* T times the rank-one part of hess l */
                if (m[a] != 0.0)
                    for (b = 0; b < n; ++b)
                        st->S[a * n + b] += T * m[a] * (m[b] / rho);
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
    at_lambda(w, st, lam);
    if (!isfinite(st->Pi) || !finite_all(st->r, (size_t)n)
        || !finite_all(st->K, (size_t)n * (size_t)n))
        return 0;
    return 1;
}

/* ---- dense linear algebra (n is small: a few flexures' coordinates) ----------------------- */

/* Cholesky factor L (lower, row-major) of the symmetric A in F; 0 if A is not positive definite */
static int cholesky_builtin(const double *A, double *F, int n)
{
    int i, j, k;
    for (i = 0; i < n; ++i)
        for (j = 0; j <= i; ++j) {
            double sum = A[i * n + j];
            for (k = 0; k < j; ++k)
                sum -= F[i * n + k] * F[j * n + k];
            if (i == j) {
                if (!(sum > 0.0))
                    return 0;
                F[i * n + i] = sqrt(sum);
            } else {
                F[i * n + j] = sum / F[j * n + j];
            }
        }
    return 1;
}

static void cholesky_solve_builtin(const double *F, int n, const double *b, double *x)
{
    int i, k;
    for (i = 0; i < n; ++i) {
        double sum = b[i];
        for (k = 0; k < i; ++k)
            sum -= F[i * n + k] * x[k];
        x[i] = sum / F[i * n + i];
    }
    for (i = n - 1; i >= 0; --i) {
        double sum = x[i];
        for (k = i + 1; k < n; ++k)
            sum -= F[k * n + i] * x[k];
        x[i] = sum / F[i * n + i];
    }
}

/* x = A^-1 b by LU with partial pivoting (A copied into F); 0 if A is singular */
static int lu_solve_builtin(const double *A, double *F, int *piv, int n, const double *b,
                            double *x)
{
    int i, j, k;
    memcpy(F, A, sizeof(double) * (size_t)n * (size_t)n);
    for (k = 0; k < n; ++k) {
        int pk = k;
        double big = fabs(F[k * n + k]);
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
                double t = F[k * n + j];
                F[k * n + j] = F[pk * n + j];
                F[pk * n + j] = t;
            }
        for (i = k + 1; i < n; ++i) {
            double m = F[i * n + k] / F[k * n + k];
            F[i * n + k] = m;
            if (m != 0.0)
                for (j = k + 1; j < n; ++j)
                    F[i * n + j] -= m * F[k * n + j];
        }
    }
    memcpy(x, b, sizeof(double) * (size_t)n);
    for (k = 0; k < n; ++k) {
        double t = x[piv[k]];
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
static int use_lapack(const fg_problem *p, int n)
{
    return p->lapack.potrf != NULL && n >= p->lapack.min_size;
}

static int cholesky(const fg_problem *p, const double *A, double *F, int n)
{
    if (use_lapack(p, n)) {
        char uplo = 'L';
        int info = 0, lda = n;
        memcpy(F, A, sizeof(double) * (size_t)n * (size_t)n);
        p->lapack.potrf(&uplo, &n, F, &lda, &info);
        return info == 0;
    }
    return cholesky_builtin(A, F, n);
}

static void cholesky_solve(const fg_problem *p, const double *F, int n, const double *b,
                           double *x)
{
    if (use_lapack(p, n)) {
        char uplo = 'L';
        int info = 0, lda = n, nrhs = 1;
        memcpy(x, b, sizeof(double) * (size_t)n);
        p->lapack.potrs(&uplo, &n, &nrhs, (double *)F, &lda, x, &lda, &info);
        return;
    }
    cholesky_solve_builtin(F, n, b, x);
}

static int lu_solve(const fg_problem *p, const double *A, double *F, int *piv, int n,
                    const double *b, double *x)
{
    if (use_lapack(p, n)) {
        char trans = 'N';
        int info = 0, lda = n, nrhs = 1;
        memcpy(F, A, sizeof(double) * (size_t)n * (size_t)n);
        p->lapack.getrf(&n, &n, F, &lda, piv, &info);
        if (info != 0)
            return 0;
        memcpy(x, b, sizeof(double) * (size_t)n);
        p->lapack.getrs(&trans, &n, &nrhs, F, &lda, piv, x, &lda, &info);
        return info == 0;
    }
    return lu_solve_builtin(A, F, piv, n, b, x);
}

static double norm2(const double *x, int n)
{
    double s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        s += x[i] * x[i];
    return sqrt(s);
}

static double norm_inf(const double *x, int n)
{
    double s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        if (fabs(x[i]) > s)
            s = fabs(x[i]);
    return s;
}

static double dot(const double *x, const double *y, int n)
{
    double s = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        s += x[i] * y[i];
    return s;
}

/* ---- symmetric eigen-decomposition (numpy.linalg.eigh) ------------------------------------ */

/* The cyclic Jacobi method: the eigenvalues of the symmetric A ascending in ev, the eigenvector
 * of ev[j] in row j of V; scratch: 2 n n. Rotations stop when every off-diagonal entry is below
 * 1e-18 of |A| (the eigenvalues are then as accurate as LAPACK's, to a few ulps of |A|). */
static void jacobi_builtin(const double *A, int n, double *ev, double *V, double *scratch)
{
    double *a = scratch, *u = scratch + (size_t)n * (size_t)n, fro = 0.0, small;
    int i, j, k, sweep, rotated = 1;
    memcpy(a, A, sizeof(double) * (size_t)n * (size_t)n);
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) {
            u[i * n + j] = i == j ? 1.0 : 0.0;
            fro += a[i * n + j] * a[i * n + j];
        }
    small = 1e-18 * sqrt(fro);
    for (sweep = 0; sweep < 100 && rotated; ++sweep) {
        rotated = 0;
        for (i = 0; i + 1 < n; ++i)
            for (j = i + 1; j < n; ++j) {
                double aij = a[i * n + j], theta, t, c, s;
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
                    double x, y;
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
        double tmp;
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
static void eigen(fg_ws *w, const double *A)
{
    const fg_problem *p = w->p;
    int n = w->n;
    if (p->lapack.syev != NULL && n >= p->lapack.min_size) {
        char jobz = 'V', uplo = 'L';
        int info = 0, lda = n, lwork = FG_LWORK(n);
        memcpy(w->eV, A, sizeof(double) * (size_t)n * (size_t)n);
        p->lapack.syev(&jobz, &uplo, &n, w->eV, &lda, w->ew, w->ework, &lwork, &info);
        if (info == 0)
            return;
    }
    jacobi_builtin(A, n, w->ew, w->eV, w->ework);
}

/* the smallest eigenvalue of A (equilibrium._min_eig); its eigenvector is row 0 of w->eV */
static double min_eig(fg_ws *w, const double *A)
{
    eigen(w, A);
    return w->n > 0 ? w->ew[0] : 0.0;
}

/* ---- Newton with a line search (equilibrium.py: _Solver.newton, _line_search) ------------- */

/* Newton from *cur (evaluated) at its load factor, using *spare (and, for descent, *extra) for
 * trial states; on success *cur points at the converged state and the others at spare buffers.
 * Plain: Newton steps with a backtracking line search on |r|, given up when the residual
 * stagnates. Descent (extra != NULL): every step a descent direction of Pi (the eigenvalues of K
 * replaced by their magnitudes, at least 1e-10 of the largest), an Armijo line search on Pi that
 * also takes a step changing Pi by rounding only if it lowers |r|, and, along negative curvature,
 * steps doubled while Pi keeps falling; it ends at a stable equilibrium or fails. */
static int newton(fg_ws *w, fg_state **cur, fg_state **spare, fg_state **extra, int max_it,
                  int *iterations)
{
    const fg_problem *p = w->p;
    int n = w->n, k, i, tries, descent = extra != NULL;
    double history[8];      /* the relative residuals of the last 8 iterations */
    for (k = 0; k <= max_it; ++k) {
        fg_state *st = *cur;
        double rn, slope = 0.0, top = 0.0, *d = w->vec3, *qt = w->vec4, alpha = 1.0;
        int accepted = 0, indefinite = 0;
        if (st->rel <= p->tol)
            return 1;
        if (k == max_it)
            break;
        history[k & 7] = st->rel;
        if (!descent && k >= 8 && st->rel > 0.5 * history[(k - 6) & 7])
            return 0;
        ++*iterations;
        rn = norm2(st->r, n);
        if (descent) {
            /* d = -V diag(1 / max(|w|, 1e-10 top)) V^T r */
            double *ew = w->ew, *V = w->eV, *c = w->cvec;
            int j;
            eigen(w, st->K);
            for (j = 0; j < n; ++j)
                if (fabs(ew[j]) > top)
                    top = fabs(ew[j]);
            if (top < 1e-300)
                top = 1e-300;
            indefinite = n > 0 && ew[0] <= 1e-10 * top;
            for (j = 0; j < n; ++j) {
                double wm = fabs(ew[j]) > 1e-10 * top ? fabs(ew[j]) : 1e-10 * top;
                c[j] = dot(V + (size_t)j * (size_t)n, st->r, n) / wm;
            }
            for (i = 0; i < n; ++i) {
                double s = 0.0;
                for (j = 0; j < n; ++j)
                    s += V[(size_t)j * (size_t)n + i] * c[j];
                d[i] = -s;
            }
            slope = dot(st->r, d, n);
        } else if (!lu_solve(p, st->K, w->la, w->piv, n, st->r, d)) {
            return 0;
        }
        for (tries = 0; tries < 30 && !accepted; ++tries, alpha *= 0.5) {
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
                if (norm2(trial->r, n) <= (1.0 - 1e-4 * alpha) * rn) {
                    *spare = st;
                    *cur = trial;
                    accepted = 1;
                }
                continue;
            }
            {
                int ok = trial->Pi <= st->Pi + 1e-4 * alpha * slope;
                int roundoff = fabs(trial->Pi - st->Pi) <= 1e-13 * (fabs(st->Pi) + fabs(st->U))
                               && norm2(trial->r, n) < rn;
                fg_state *best = trial, *cand = *extra;
                if (!(ok || roundoff))
                    continue;
                if (ok && indefinite && alpha >= 1.0) {
                    /* negative curvature: expand while the potential keeps falling */
                    double a = alpha;
                    int e;
                    for (e = 0; e < 40; ++e) {
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
        if (!accepted)
            return 0;
    }
    return 0;
}

/* every smooth curvature flexure within its range (SCMModel.in_range): the polynomial kernel's
 * when it has one (an "auto" flexure past it would switch kernels), else the Gauss kernel's
 * certified range */
static int in_kernel_range(const fg_problem *p, const double *q)
{
    int i;
    for (i = 0; i < p->nflex; ++i) {
        const fg_flexure *f = &p->flex[i];
        fg_range in_range = f->poly != NULL ? f->in_range : f->gauss_in_range;
        if (f->kind == FG_MODEL_KERNEL && in_range != NULL && !in_range(q + f->offset))
            return 0;
    }
    return 1;
}

/* ---- the solve ---------------------------------------------------------------------------- */

/* polish the equilibrium *cur, then the answer: q, the output points' poses and compliances */
static int finish(fg_ws *w, fg_state *cur, fg_state *spare, int iterations, fg_answer *out)
{
    const fg_problem *p = w->p;
    int n = w->n, i, j, a;
    /* polish: plain Newton steps while they lower the relative residual below 1e-14 */
    for (j = 0; j < 3 && cur->rel > 1e-14; ++j) {
        double *d = w->vec3, *qt = w->vec4;
        if (!lu_solve(p, cur->K, w->la, w->piv, n, cur->r, d))
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
    }

    /* the answer: kinematics at the equilibrium, compliance J K^-1 J^T of the output points */
    if (!kinematics(w, cur->q))
        return FG_MODEL_ERROR;
    out->stable = cholesky(p, cur->K, w->la, n);
    out->iterations = iterations;
    out->energy = cur->U;
    out->residual = cur->rel;
    memcpy(out->q, cur->q, sizeof(double) * (size_t)n);
    if (out->stiffness != NULL)
        memcpy(out->stiffness, cur->K, sizeof(double) * (size_t)n * (size_t)n);
    for (j = 0; j < p->noutputs; ++j) {
        int pt = p->outputs[j];
        const double *J = w->pJ + (size_t)3 * n * pt;
        double *C = out->compliance + 9 * j, *X = w->lc;   /* X = K^-1 J^T, 3 columns */
        int ok = 1;
        memcpy(out->pose + 3 * j, w->ppose + 3 * pt, sizeof(double) * 3);
        for (a = 0; a < 3 && ok; ++a) {
            if (out->stable)
                cholesky_solve(p, w->la, n, J + a * n, X + a * n);
            else
                ok = lu_solve(p, cur->K, w->lb, w->piv, n, J + a * n, X + a * n);
        }
        for (a = 0; a < 3; ++a)
            for (i = 0; i < 3; ++i) {
                double sum = 0.0;
                int m;
                for (m = 0; m < n; ++m)
                    sum += J[a * n + m] * X[i * n + m];
                C[a * 3 + i] = ok ? sum : NAN;
            }
        for (a = 0; a < 3; ++a)
            for (i = 0; i < a; ++i) {
                double s = 0.5 * (C[a * 3 + i] + C[i * 3 + a]);
                C[a * 3 + i] = C[i * 3 + a] = s;
            }
    }
    return FG_SOLVED;
}

/* The full load in one Newton solve from the unloaded state *st0 (equilibrium._direct_solve):
 * 1 with the equilibrium in *cur if every check passes, else 0 (the continuation runs). */
static int direct_solve(fg_ws *w, const fg_state *st0, fg_state **cur, fg_state **spare,
                        fg_state *smp, int *iterations)
{
    const fg_problem *p = w->p;
    int n = w->n, i, j, max_it = p->max_iterations < 12 ? p->max_iterations : 12;
    double *t0 = w->t0, *t1 = w->t1;     /* path tangents dq/dlam at the two ends */
    const double samples[3] = {0.25, 0.5, 0.75};
    fg_state *c = *cur;

    cholesky_solve(p, w->la, n, st0->Q, t0);     /* la: K(q0, 0), factored by the caller */
    memcpy(c->q, st0->q, sizeof(double) * (size_t)n);
    memcpy(c->gU, st0->gU, sizeof(double) * (size_t)n);
    memcpy(c->QL, st0->QL, sizeof(double) * (size_t)n);
    memcpy(c->QT, st0->QT, sizeof(double) * (size_t)n);
    memcpy(c->S, st0->S, sizeof(double) * (size_t)n * (size_t)n);
    c->U = st0->U;
    c->W = st0->W;
    c->V = st0->V;
    c->gmax = st0->gmax;
    c->rmax = st0->rmax;
    at_lambda(w, c, 1.0);
    if (!cholesky(p, c->K, w->la, n))
        return 0;                 /* the full load may buckle the unloaded state */
    if (!newton(w, cur, spare, NULL, max_it, iterations))
        return 0;
    c = *cur;
    if (!cholesky(p, c->K, w->la, n))
        return 0;
    cholesky_solve(p, w->la, n, c->Q, t1);
    if (!in_kernel_range(p, c->q))
        return 0;
    /* the cubic Hermite path between the ends: stable and close to equilibrium where sampled */
    for (j = 0; j < 3; ++j) {
        double t = samples[j], *qt = w->vec4, *corr = w->vec3;
        double h00 = 2 * t * t * t - 3 * t * t + 1, h10 = t * t * t - 2 * t * t + t;
        double h01 = -2 * t * t * t + 3 * t * t, h11 = t * t * t - t * t;
        for (i = 0; i < n; ++i)
            qt[i] = h00 * st0->q[i] + h10 * t0[i] + h01 * c->q[i] + h11 * t1[i];
        if (!evaluate(w, qt, t, smp) || !cholesky(p, smp->K, w->la, n))
            return 0;
        cholesky_solve(p, w->la, n, smp->r, corr);
        if (!(norm_inf(corr, n) <= 0.2 * p->max_dq) || !in_kernel_range(p, qt))
            return 0;
    }
    return 1;
}

/* ---- stability along the path (equilibrium.py: _is_bifurcation, _cross_bifurcation) ------- */

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

/* a critical load factor of this kind, in order; 0 if the caller's array is full */
static int record_critical(fg_answer *out, double lam, int kind)
{
    if (out->critical == NULL || out->critical_kind == NULL
        || out->ncritical >= out->max_critical)
        return 0;
    out->critical[out->ncritical] = lam;
    out->critical_kind[out->ncritical] = kind;
    ++out->ncritical;
    return 1;
}

/* Newton with descent from q at load factor lam, up to 20 max_iterations (the snap-through and
 * the leaving of an unstable branch in equilibrium.py); the stable equilibrium it ends at, or
 * NULL. The states keep and keep2 are not touched. */
static fg_state *descend(fg_ws *w, const double *q, double lam, const fg_state *keep,
                         const fg_state *keep2, int *iterations)
{
    fg_state *a = free_state(w, keep, keep2, NULL, NULL);
    fg_state *b = free_state(w, keep, keep2, a, NULL);
    fg_state *c = free_state(w, keep, keep2, a, b);
    if (!evaluate(w, q, lam, a)
        || !newton(w, &a, &b, &c, 20 * w->p->max_iterations, iterations)
        || !cholesky(w->p, a->K, w->la, w->n))
        return NULL;
    return a;
}

/* At a bifurcation the load does no work along the lost mode v (the eigenvector of K's smallest
 * eigenvalue): |v . Q| <= 1e-6 (|Q| + |lam S|), |lam S| the Frobenius norm of the load part of K.
 * Its sign does not matter. */
static int is_bifurcation(fg_ws *w, const fg_state *b)
{
    int n = w->n, i;
    double kg = 0.0, scale;
    min_eig(w, b->K);
    for (i = 0; i < n * n; ++i) {
        double g = b->lam * b->S[i];
        kg += g * g;
    }
    scale = norm2(b->Q, n) + sqrt(kg);
    return scale > 0.0 ? fabs(dot(w->eV, b->Q, n)) <= 1e-6 * scale : 1;
}

/* the mean world y and angle of the output points at s's q; 0 if the kinematics fail */
static int mean_output(fg_ws *w, const fg_state *s, double *y, double *angle)
{
    const fg_problem *p = w->p;
    int j;
    *y = *angle = 0.0;
    if (p->noutputs == 0)
        return 1;
    if (!kinematics(w, s->q))
        return 0;
    for (j = 0; j < p->noutputs; ++j) {
        *y += w->ppose[3 * p->outputs[j] + 1];
        *angle += w->ppose[3 * p->outputs[j] + 2];
    }
    *y /= p->noutputs;
    *angle /= p->noutputs;
    return 1;
}

/* The path went from the stable *a through a bifurcation to the unstable *b: the critical load
 * factor by regula falsi (Illinois) on the smallest eigenvalue with Newton at each trial load
 * factor, then the stable side at b's load factor, by descent from b +- eps v (eps = 1e-3
 * max(1, |q_b|)): the only stable one found, else the one of lower potential, else (symmetric)
 * the one whose output points lie higher (mean world y), else the counter-clockwise one. The
 * chosen state (in the pool) with the critical load factor recorded, or NULL. */
static fg_state *cross_bifurcation(fg_ws *w, fg_state *a, fg_state *b, int *iterations,
                                   fg_answer *out)
{
    const fg_problem *p = w->p;
    int n = w->n, i, it, side = 0, why;
    fg_state *lo = a, *hi = b, *s1, *s2, *choice;
    double mu_lo = min_eig(w, a->K), mu_hi = min_eig(w, b->K);
    double e_lo = mu_lo, e_hi = mu_hi;       /* the eigenvalues themselves (no Illinois halving) */
    double lam_c, eps, lam_b = b->lam, *qm = w->t1, *v = w->vmin;
    for (it = 0; it < 100; ++it) {
        double t, lam_m, mu_m, kmax = 1.0;
        fg_state *m, *m2;
        if (hi->lam - lo->lam <= 1e-13 * (hi->lam > 1.0 ? hi->lam : 1.0))
            break;
        t = mu_lo != mu_hi ? mu_lo / (mu_lo - mu_hi) : 0.5;
        t = t > 0.01 ? t : 0.01;
        t = t < 0.99 ? t : 0.99;
        lam_m = lo->lam + t * (hi->lam - lo->lam);
        for (i = 0; i < n; ++i)
            qm[i] = lo->q[i] + t * (hi->q[i] - lo->q[i]);
        m = free_state(w, lo, hi, b, NULL);
        m2 = free_state(w, lo, hi, b, m);
        if (!evaluate(w, qm, lam_m, m) || !newton(w, &m, &m2, NULL, p->max_iterations, iterations))
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
        for (i = 0; i < n * n; ++i)
            if (fabs(m->K[i]) > kmax)
                kmax = fabs(m->K[i]);
        if (fabs(mu_m) <= 1e-13 * kmax)
            break;
    }
    lam_c = e_lo == e_hi ? lo->lam : lo->lam + e_lo / (e_lo - e_hi) * (hi->lam - lo->lam);

    /* leave the unstable branch at b's load factor: descend from b +- eps v */
    min_eig(w, b->K);
    memcpy(v, w->eV, sizeof(double) * (size_t)n);
    eps = 1e-3 * (norm2(b->q, n) > 1.0 ? norm2(b->q, n) : 1.0);
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
        double scale = 1e-300, y1, y2, th1, th2, ys;
        if (fabs(s1->Pi) > scale)
            scale = fabs(s1->Pi);
        if (fabs(s2->Pi) > scale)
            scale = fabs(s2->Pi);
        if (fabs(s1->U) > scale)
            scale = fabs(s1->U);
        if (fabs(s2->U) > scale)
            scale = fabs(s2->U);
        if (fabs(s1->Pi - s2->Pi) > 1e-9 * scale) {
            choice = s1->Pi < s2->Pi ? s1 : s2;
            why = FG_BUCKLING_LOWER_ENERGY;
        } else {
            if (!mean_output(w, s1, &y1, &th1) || !mean_output(w, s2, &y2, &th2))
                return NULL;
            ys = fabs(y1) > fabs(y2) ? fabs(y1) : fabs(y2);
            if (fabs(y1 - y2) > 1e-9 * (ys > 1e-300 ? ys : 1e-300)) {
                choice = y1 > y2 ? s1 : s2;
                why = FG_BUCKLING_LARGER_Y;
            } else {
                choice = th1 >= th2 ? s1 : s2;
                why = FG_BUCKLING_COUNTER_CLOCKWISE;
            }
        }
    }
    return record_critical(out, lam_c, why) ? choice : NULL;
}

/* Load continuation from the stable state *path (lam = 0) to lam = 1 (equilibrium.solve's
 * loop): adaptive steps, a tangent predictor while K is positive definite, Newton at each load
 * factor, a step that changes a coordinate by more than max_dq counts as a jump. A step from a
 * stable state onto an unstable one is a bifurcation (crossed: cross_bifurcation) or else the
 * unstable side of a limit point (a shorter step); where the path ends (no step even at
 * min_step) the solve descends to the equilibrium it snaps to. The equilibrium at lam = 1 (a
 * state of the pool), or NULL (hand back to the Python solver: the step budget runs out, no
 * stable state past a bifurcation or a limit point, the critical array is full). */
static fg_state *continuation(fg_ws *w, fg_state *path, int *iterations, fg_answer *out)
{
    const fg_problem *p = w->p;
    int n = w->n, i, steps = 0;
    double lam = 0.0, dlam = p->initial_step;
    while (lam < 1.0) {
        double lam_n = lam + dlam < 1.0 ? lam + dlam : 1.0;
        int it0 = *iterations, used, found = 0, attempt, stable_before;
        fg_state *a = free_state(w, path, NULL, NULL, NULL);
        fg_state *b = free_state(w, path, a, NULL, NULL);
        if (++steps > p->max_steps)
            return NULL;
        stable_before = cholesky(p, path->K, w->la, n);
        for (attempt = 0; attempt < 2 && !found; ++attempt) {
            double *start = w->vec1;
            if (attempt == 0) {            /* the tangent predictor */
                if (!stable_before)
                    continue;
                cholesky_solve(p, w->la, n, path->Q, w->t0);
                for (i = 0; i < n; ++i)
                    start[i] = path->q[i] + (lam_n - lam) * w->t0[i];
            } else {
                memcpy(start, path->q, sizeof(double) * (size_t)n);
            }
            if (!evaluate(w, start, lam_n, a)
                || !newton(w, &a, &b, NULL, p->max_iterations, iterations))
                continue;
            for (i = 0; i < n; ++i)
                w->vec2[i] = a->q[i] - path->q[i];
            found = norm_inf(w->vec2, n) <= p->max_dq;
        }
        used = *iterations - it0;
        if (found && stable_before && !cholesky(p, a->K, w->la, n)) {
            if (is_bifurcation(w, a)) {
                fg_state *next = cross_bifurcation(w, path, a, iterations, out);
                if (next == NULL)
                    return NULL;
                path = next;
                lam = lam_n;
                dlam = p->initial_step;
                continue;
            }
            found = 0;            /* the unstable side of a limit point: a shorter step */
        }
        if (!found) {
            fg_state *next;
            if (dlam > p->min_step) {
                dlam = 0.5 * dlam > p->min_step ? 0.5 * dlam : p->min_step;
                continue;
            }
            /* the path ends here (a limit point): descend to the equilibrium it snaps to */
            next = descend(w, path->q, lam_n, path, NULL, iterations);
            if (next == NULL || !record_critical(out, lam, FG_SNAP_THROUGH))
                return NULL;
            path = next;
            lam = lam_n;
            dlam = p->initial_step;
            continue;
        }
        if (used <= 3)
            dlam = 2.0 * dlam < p->max_step ? 2.0 * dlam : p->max_step;
        else if (used <= 6)
            dlam = 1.2 * dlam < p->max_step ? 1.2 * dlam : p->max_step;
        path = a;
        lam = lam_n;
    }
    return path;
}

static void clear_switched(fg_ws *w)
{
    memset(w->switched, 0, sizeof(int) * (size_t)w->p->nflex);
}

static int any_switched(const fg_ws *w)
{
    int i;
    for (i = 0; i < w->p->nflex; ++i)
        if (w->switched[i])
            return 1;
    return 0;
}

int fg_solve(const fg_problem *p, double *work, int *iwork, fg_answer *out)
{
    fg_ws ws, *w = &ws;
    fg_state *st0, *cur, *spare, *smp;
    int n = p->ndof, i, j, iterations = 0;

    bind(w, p, work, iwork);
    st0 = &w->st[0];
    cur = &w->st[1];
    spare = &w->st[2];
    smp = &w->st[3];
    out->iterations = 0;
    out->stable = 0;
    out->ncritical = 0;

    clear_switched(w);
    if (p->q0 != NULL) {
        /* warm start (equilibrium._warm_start): Newton at the full load from q0, accepted if it
         * converges to a stable equilibrium within max_dq of q0 */
        if (!evaluate(w, p->q0, 1.0, cur)
            || !newton(w, &cur, &spare, NULL, p->max_iterations, &iterations)
            || !cholesky(p, cur->K, w->la, n))
            return FG_FALLBACK;
        for (i = 0; i < n; ++i)
            w->vec4[i] = cur->q[i] - p->q0[i];
        if (norm_inf(w->vec4, n) > p->max_dq)
            return FG_FALLBACK;
    } else {
        /* the unloaded state (q = 0, lam = 0: an equilibrium), then the full load at once, else
         * the continuation from it */
        memset(w->vec1, 0, sizeof(double) * (size_t)n);
        if (!evaluate(w, w->vec1, 0.0, st0))
            return FG_MODEL_ERROR;
        if (!cholesky(p, st0->K, w->la, n))
            return FG_FALLBACK;
        if (p->max_steps < 1)
            return FG_FALLBACK;
        if (direct_solve(w, st0, &cur, &spare, smp, &iterations)) {
            clear_switched(w);    /* trial steps past a kernel's range are no part of the path */
        } else {
            iterations = 0;       /* a rejected direct attempt leaves no trace */
            clear_switched(w);
            cur = continuation(w, st0, &iterations, out);
            if (cur == NULL)
                return FG_FALLBACK;
            spare = free_state(w, cur, NULL, NULL, NULL);
        }
    }
    i = finish(w, cur, spare, iterations, out);
    /* a kernel switch on the way (even on a trial step) is reported per flexure, for the
     * Python solver's warning; a caller that takes no flags gets the solve handed back */
    if (i == FG_SOLVED && any_switched(w)) {
        if (out->switched == NULL)
            return FG_FALLBACK;
        for (j = 0; j < p->nflex; ++j)
            out->switched[j] = w->switched[j];
    } else if (i == FG_SOLVED && out->switched != NULL) {
        for (j = 0; j < p->nflex; ++j)
            out->switched[j] = 0;
    }
    return i;
}
