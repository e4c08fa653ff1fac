/* The chain solver's problem description and answer (the solver: chain_solver.c).
 *
 * This header is the single definition of the interface: flexgen/problem.py fills these structs
 * from a scene by field name through cffi (this header, less its preprocessor lines, is the
 * cffi declaration), flexgen/solver.py reads the answer; a C program fills them itself. C99;
 * also valid C++.
 */
#ifndef FLEXGEN_CHAIN_SOLVER_H
#define FLEXGEN_CHAIN_SOLVER_H

#include <stddef.h>

/* the linkage of the functions below: external by default; `flexgen generate --scene` defines it
 * as `static` before pasting this core into a controller's one translation unit, so that two
 * emitted mechanisms link into one program */
#ifndef FG_API
#define FG_API
#endif

/* the floating-point type of every quantity but the settings: double; `flexgen generate --scene
 * --float` defines FG_REAL as float (with <tgmath.h>, so that the math functions follow it) for
 * its single-precision twin */
#ifndef FG_REAL
#define FG_REAL double
#endif
typedef FG_REAL fg_real;

#ifdef __cplusplus
extern "C" {
#endif

/* a generated kernel: pose (3), J (3 x k), H (3 x k x k) of the tip in units of L */
typedef void (*fg_kernel)(const fg_real *q, fg_real *pose, fg_real *J, fg_real *H);
typedef int (*fg_range)(const fg_real *q);

enum { FG_MODEL_KERNEL = 0, FG_MODEL_FEM = 1, FG_MODEL_PRB = 2 };

/* fg_solve's status: an equilibrium (fg_answer holds it), none (fg_answer.failure says why and
 * where; the solve ran to its end as the algorithm prescribes, nothing is left to try), or an
 * fg_problem the solver cannot run (malformed input: a negative count, an index out of range, a
 * missing array or kernel; fg_answer is not filled) */
enum { FG_SOLVED = 0, FG_NO_EQUILIBRIUM = 1, FG_MODEL_ERROR = 2 };

/* why no equilibrium was found (fg_answer.failure) */
enum {
    FG_FAIL_NONE = 0,
    FG_FAIL_UNLOADED = 1,       /* no equilibrium of the unloaded scene */
    FG_FAIL_STEPS = 2,          /* the continuation needed more than max_steps steps */
    FG_FAIL_BIFURCATION = 3,    /* no stable equilibrium past a bifurcation */
    FG_FAIL_LIMIT = 4           /* no equilibrium beyond a load factor (the path ended) */
};

/* the last error met on the way (fg_answer.last_error; flexgen/reasons.py words it) */
enum {
    FG_ERR_NONE = 0,
    FG_ERR_STAGNATION = 1,      /* Newton stagnated (at a load factor, a relative residual) */
    FG_ERR_NOT_CONVERGED = 2,   /* Newton did not converge in last_error_iterations iterations */
    FG_ERR_LINE_SEARCH = 3,     /* the line search failed (at a load factor, a residual) */
    FG_ERR_JUMP = 4,            /* the path jumped: by more than max_dq, against its
                                 * tangent onto another branch, or off the path between
                                 * its ends (at a load factor) */
    FG_ERR_NONFINITE = 5,       /* a model returned a non-finite value */
    FG_ERR_KERNEL_RANGE = 6,    /* a polynomial-only kernel past its range (*_error_flexure) */
    FG_ERR_TENDON = 7           /* a tendon segment of zero length (*_error_route) */
};

/* the kind of a critical event on the load path (fg_answer.critical_kind): the path ended at a
 * limit point and the solve snapped through, or it crossed a bifurcation and took the stable side
 * chosen for this reason (flexgen/solver.py: BUCKLING_SIDES[kind - 1] is its text) */
enum {
    FG_SNAP_THROUGH = 0,
    FG_BUCKLING_ONLY_SIDE = 1,          /* the only stable side found */
    FG_BUCKLING_LOWER_ENERGY = 2,       /* the side of lower potential energy */
    FG_BUCKLING_LARGER_Y = 3,           /* symmetric: the side of larger world y */
    FG_BUCKLING_COUNTER_CLOCKWISE = 4   /* symmetric: the counter-clockwise side */
};

typedef struct {
    int kind;             /* FG_MODEL_* */
    int ndof;             /* its coordinates are q[offset .. offset + ndof) */
    int offset;
    int parent;           /* flexure whose tip frame carries this root (listed earlier), -1: base */
    fg_real at[3];         /* root frame in the parent frame: x, y, angle */
    fg_real length;
    fg_real gamma;         /* FG_MODEL_PRB: pin position */
    fg_kernel poly;       /* FG_MODEL_KERNEL: polynomial kernel (NULL: none) */
    fg_range in_range;    /* its range check */
    fg_kernel gauss;      /* Gauss kernel (NULL: none) */
    fg_range gauss_in_range;   /* its certified range */
    fg_kernel local;      /* local Gauss kernel (NULL: none), tried first: where local_in_range
                           * certifies its bound at q; then poly within its range, then gauss */
    fg_range local_in_range;
    const fg_real *tip0;  /* FG_MODEL_KERNEL: NULL, or the kernel's value at q = 0 as it returns
                           * it (pose 3, J 3 x ndof, H 3 x ndof x ndof, for length 1): a constant
                           * of the model, so the unloaded state evaluates no kernel */
} fg_flexure;

/* optional LAPACK routines (Fortran calling convention), e.g. scipy's; NULL: the built-in
 * (unblocked) factorizations, which are as fast for a few coordinates */
typedef void (*fg_potrf)(char *uplo, int *n, double *a, int *lda, int *info);
typedef void (*fg_potrs)(char *uplo, int *n, int *nrhs, double *a, int *lda, double *b, int *ldb,
                         int *info);
typedef void (*fg_getrf)(int *m, int *n, double *a, int *lda, int *ipiv, int *info);
typedef void (*fg_getrs)(char *trans, int *n, int *nrhs, double *a, int *lda, int *ipiv,
                         double *b, int *ldb, int *info);
typedef void (*fg_syev)(char *jobz, char *uplo, int *n, double *a, int *lda, double *w,
                        double *work, int *lwork, int *info);

typedef struct {
    fg_potrf potrf;       /* called with uplo 'L' */
    fg_potrs potrs;       /* not called: the solves with its factor are built in */
    fg_getrf getrf;
    fg_getrs getrs;
    fg_syev syev;         /* symmetric eigen-decomposition (NULL: the built-in Jacobi method) */
} fg_lapack;            /* used from fg_settings.lapack_min_size coordinates on */

/* Every tuning constant of the solver. The fields mirror flexgen/settings.py (SolverSettings:
 * the same names, order and types, with the defaults and their validation), and Python copies
 * them by name; no default is written in C. The solver checks only what memory safety needs
 * (1 <= stagnation_lag <= FG_MAX_LAG, else FG_MODEL_ERROR): a caller from C fills every field
 * with a value SolverSettings would accept. */
#define FG_MAX_LAG 64
typedef struct {
    double tol;                     /* relative residual of an accepted equilibrium */
    double max_dq;                  /* largest change of a coordinate in one step along the path
                                     * (a warm start: of an angle along a flexure, angle_change) */
    int max_iterations;             /* Newton iterations per load step */
    int max_steps;                  /* continuation steps */
    double initial_step;            /* load-factor step of the continuation: first, */
    double max_step;                /* largest, */
    double min_step;                /* smallest */
    double polish_target;           /* polishing: Newton steps while the residual is above this */
    int polish_steps;               /* polishing: at most this many steps */
    int direct_max_iterations;      /* direct solve: Newton iterations (and max_iterations) */
    double direct_correction;       /* direct solve: largest Newton correction at a path sample,
                                     * as a fraction of max_dq */
    int direct_samples;             /* direct solve: path samples at t = k / (direct_samples + 1) */
    int stagnation_after;           /* Newton stagnates: from this iteration on, */
    double stagnation_ratio;        /* the residual above this fraction of */
    int stagnation_lag;             /* the residual this many iterations earlier */
    double armijo;                  /* sufficient-decrease factor of the line searches */
    int line_search_halvings;       /* line search: at most this many step lengths tried */
    int expansion_doublings;        /* descent: step doublings along negative curvature */
    double eigenvalue_floor;        /* descent: eigenvalue magnitudes floored at this fraction of
                                     * the largest (and below it K counts as indefinite) */
    double roundoff_tol;            /* descent: a change of the potential below this fraction of
                                     * |Pi| + |U| is rounding */
    double bifurcation_threshold;   /* |v . Q| <= this (|Q| + |lam S|): a bifurcation */
    double bracket_tol;             /* regula falsi: stop at a load-factor interval of this
                                     * fraction of max(1, lam), or an eigenvalue of this fraction
                                     * of max(1, |K|) */
    int bracket_iterations;         /* regula falsi: at most this many trial load factors */
    double bracket_clamp;           /* regula falsi: trial fraction of the interval kept in
                                     * [clamp, 1 - clamp] */
    double descent_eps;             /* leaving a bifurcation: start at q +- eps max(1, |q|) v */
    int descent_iteration_factor;   /* descent Newton: this many max_iterations */
    double tie_tol;                 /* potentials (and mean y) equal to this relative tolerance */
    int fast_iterations;            /* a step that took at most this many iterations: */
    double fast_growth;             /* the next step is this much longer; */
    int moderate_iterations;        /* at most this many iterations: */
    double moderate_growth;         /* this much longer */
    double step_shrink;             /* a failed step: the next one this fraction of it */
    int lapack_min_size;            /* LAPACK (fg_lapack) from this many coordinates on */
    int elimination_min_size;       /* from this many coordinates on, K is factorized by first
                                     * eliminating each flexure's coordinates that couple only
                                     * within it and with the angles (chain_solver.c) */
    int bend_samples;               /* fg_answer.bend: points along each flexure (>= 1) */
    double circle_tol;              /* an ellipse whose axes differ by less than this (relative)
                                     * is a circle: its angle is 0 */
    double linearized_step;         /* Newton's last step taken unevaluated (its end linearized)
                                     * from a residual of at most this many tol, when the
                                     * convergence seen predicts its end below tol and
                                     * polish_target (0: every step evaluated) */
    int warm_on_path;               /* a warm start (fg_problem.q0) is accepted only where its
                                     * equilibrium passes the direct solve's path samples from
                                     * the unloaded state (the answer a cold solve gives); 0:
                                     * wherever Newton from q0 converges to a stable one within
                                     * max_dq (it follows q0's branch) */
} fg_settings;

typedef struct {
    int frame;            /* flexure whose tip frame carries the point, -1: base */
    fg_real x, y;          /* in that frame */
} fg_point;

typedef struct {
    int ndof, nflex, npoints, nloads, ntendons, noutputs;
    const fg_flexure *flex;      /* nflex, every parent before its children */
    const fg_point *points;      /* npoints */
    const int *load_point;       /* nloads */
    const fg_real *load;          /* 3 nloads: fx, fy, moment */
    const fg_real *tension;       /* ntendons */
    const int *route_start;      /* ntendons: first entry in route */
    const int *route_len;        /* ntendons */
    const int *route;            /* point indices */
    const int *outputs;          /* noutputs point indices */
    const fg_real *stiffness;     /* ndof: the elastic stiffness D, diagonal of the elastic energy's
                                  * Hessian (unloaded; not fg_answer.stiffness, the loaded K) */
    fg_settings settings;
    fg_lapack lapack;
    const fg_real *q0;            /* NULL, or a warm start: Newton at the full load from q0 */
    /* the validity screen of an answer (fg_answer.calm): NULL, none; else nflex bend limits
     * (rad, fg_problem.flex order) and the margin to a critical load below which an answer is
     * near one (flexgen/validity.py sets both) */
    const fg_real *bend_limit;
    fg_real near_margin;
} fg_problem;

typedef struct {
    fg_real *q;            /* ndof: the equilibrium */
    fg_real *pose;         /* 3 noutputs: world x, y, angle */
    fg_real *compliance;   /* 9 noutputs: 3 x 3 d(x, y, angle)/d(fx, fy, moment) */
    fg_real *stiffness;    /* ndof x ndof: the stiffness K at the equilibrium (NULL: not wanted) */
    fg_real energy, residual;
    int iterations, stable;
    fg_real *critical;     /* max_critical: the critical load factors met on the way, in order */
    int *critical_kind;   /* max_critical: FG_SNAP_THROUGH or FG_BUCKLING_* of each */
    int max_critical;     /* their capacity: only the first max_critical events are stored */
    int ncritical;        /* how many were met (every one, also those beyond max_critical) */
    int *switched;        /* nflex (in fg_problem.flex order): 1 if that flexure's first kernel
                           * (polynomial or local) left its range and its Gauss kernel took
                           * over during the solve; NULL: not reported */
    /* FG_NO_EQUILIBRIUM: why (FG_FAIL_*) and at which load factor (the reason's lam) */
    int failure;
    fg_real failure_load_factor;
    /* the last error of the solve, what its message prints (flexgen/reasons.py) */
    int last_error;                 /* FG_ERR_* */
    fg_real last_error_load_factor;  /* STAGNATION, LINE_SEARCH, JUMP */
    fg_real last_error_residual;     /* STAGNATION, NOT_CONVERGED, LINE_SEARCH: relative */
    int last_error_iterations;      /* NOT_CONVERGED: the iteration limit */
    int last_error_flexure;         /* KERNEL_RANGE: the flexure (index in fg_problem.flex) */
    int last_error_route;           /* TENDON: index in fg_problem.route of the zero-length
                                     * segment's first point (its second point follows it) */
    /* the last model error: FG_ERR_NONE, KERNEL_RANGE or TENDON, with its flexure or route
     * entry as above (-1: none); cleared after each accepted continuation step and after a
     * rejected warm start, so that it names a model error the solve did not get past */
    int model_error;
    int model_error_flexure;
    int model_error_route;
    int evaluations;      /* chain evaluations in the solve that evaluated a model: each
                           * kernel or n-element chain or pseudo-rigid body (not counted: the
                           * unloaded state of a chain of kernel flexures with tip0) */
    /* FG_SOLVED: what the validity of the answer depends on, at the equilibrium (and
     * fg_margin, on request) */
    fg_real *bend;         /* nflex (fg_problem.flex order): max |phi(s)| of each flexure relative
                           * to its root frame, rad, on settings.bend_samples points; NULL: not
                           * wanted */
    int *kernel;          /* nflex: the kernel evaluating each flexure at the equilibrium
                           * (FG_KERNEL_*); NULL: not wanted */
    fg_real *ellipse;      /* 3 noutputs: each output's compliance ellipse (fg_ellipse of the
                           * position rows of its compliance); NULL: not wanted */
    int warm;             /* 1: the warm start from fg_problem.q0 was accepted (the answer is
                           * Newton's from q0, no load path was followed) */
    int undefined_compliance;   /* FG_SOLVED: how many output points' compliances have an entry
                                 * that is not finite (K singular) */
    int calm;             /* FG_SOLVED with fg_problem.bend_limit and bend, kernel and stiffness
                           * asked for: 1 if every flexure's bend is within its limit, every
                           * kernel flexure's kernel within its certified set at the answer, and
                           * the answer unstable or its margin to a critical load above
                           * near_margin (fg_margin_above); else 0 (a validity warning may
                           * apply: flexgen/validity.py's check decides) */
} fg_answer;

/* fg_answer.kernel: which kernel evaluates a FG_MODEL_KERNEL flexure at the equilibrium */
enum {
    FG_KERNEL_NONE = 0,         /* not a kernel model (fem, prb) */
    FG_KERNEL_POLY = 1,         /* the polynomial kernel, within its range */
    FG_KERNEL_POLY_PAST = 2,    /* past the range of the first kernels (polynomial or local) and
                                 * no Gauss kernel */
    FG_KERNEL_GAUSS = 3,        /* the Gauss kernel, within its certified range */
    FG_KERNEL_GAUSS_PAST = 4,   /* the Gauss kernel past its certified range */
    FG_KERNEL_LOCAL = 5         /* the local Gauss kernel, certified at the equilibrium */
};

FG_API size_t fg_work_size(const fg_problem *p);
FG_API size_t fg_iwork_size(const fg_problem *p);
FG_API int fg_solve(const fg_problem *p, fg_real *work, int *iwork, fg_answer *out);

/* The margin of a stiffness K (n x n, row-major, full; e.g. fg_answer.stiffness) to a critical
 * load: the smallest eigenvalue of D^-1/2 K D^-1/2, D = diag(p->stiffness) the elastic energy's
 * Hessian (the generalized eigenvalue of (K, D)): 1 unloaded, 1 - P/P_cr on an axial load below
 * buckling, 0 at a critical load, < 0 unstable; NAN if some stiffness is not positive. The
 * eigenvalues alone (LAPACK's dsyev from settings.lapack_min_size coordinates on, else the
 * built-in tridiagonal QL method, with the Jacobi method behind it) in the solver's workspace
 * (fg_work_size, fg_iwork_size), so it is not part of fg_solve: O(n^3), asked for when an
 * answer's validity is assessed. */
FG_API fg_real fg_margin(const fg_problem *p, const fg_real *K, fg_real *work, int *iwork);

/* 1 if the margin of K to a critical load (fg_margin) exceeds margin, else 0 (also if some
 * stiffness is not positive): one Cholesky factorization of K - margin D, for the check that
 * needs only the comparison (an answer near a critical load) and not the eigenvalue. */
FG_API int fg_margin_above(const fg_problem *p, const fg_real *K, fg_real margin, fg_real *work,
                           int *iwork);

/* fg_answer.calm of a solved answer (out, as fg_solve filled it, with bend, kernel and stiffness)
 * under fg_problem.bend_limit and near_margin: the screen fg_solve applies to its own answers,
 * for an answer solved before the screen was given (one Cholesky factorization, in the solver's
 * workspace) */
FG_API int fg_calm(const fg_problem *p, const fg_answer *out, fg_real *work, int *iwork);

/* The compliance ellipse of a 2 x 2 compliance C (row-major, symmetrized): out = major, minor
 * eigenvalue (major >= minor) and the angle of the major axis from the x axis in (-pi/2, pi/2],
 * 0 when major - minor <= circle_tol max(|major|, |minor|) (a circle); NAN if C is not finite.
 * Closed form: major = (a + d)/2 + hypot((a - d)/2, b), minor = det C / major (no cancellation
 * on a thin ellipse), angle = atan2(2 b, a - d) / 2. */
FG_API void fg_ellipse(const fg_real *C, fg_real circle_tol, fg_real *out);

/* One flexure's tip pose (3), J (3 x k) and H (3 x k x k) in its root frame, physical units, at
 * its coordinates q, as the solver evaluates it (the one implementation of the n-element chain
 * and the pseudo-rigid body with their derivatives; flexgen.models.fem and .prb call it, and
 * their NumPy tip_poses repeat only the pose, tested against it); scratch: 4 (k + 1) doubles.
 * 0 if the model cannot be evaluated at q (a polynomial-only kernel past its range). */
FG_API int fg_flexure_tip(const fg_flexure *f, const fg_real *q, fg_real *pose, fg_real *J, fg_real *H,
                   fg_real *scratch);

/* fg_estimate's status */
enum {
    FG_ESTIMATED = 0,               /* out holds the differences */
    FG_ESTIMATE_NO_EVALUATION = 1,  /* the richer model cannot be evaluated near the answer */
    FG_ESTIMATE_UNSTABLE = 2,       /* its stiffness is not positive definite there */
    FG_ESTIMATE_UNDEFINED = 3,      /* a difference is not finite */
    FG_ESTIMATE_FAR = 4,            /* Newton from the answer does not converge to it (within
                                     * max_iterations and reach): solve the richer model */
    FG_ESTIMATE_MALFORMED = 5       /* a malformed problem or a missing array */
};

/* The error estimate of an answer: its differences to a richer model of the same scene (the
 * same points, loads, tendons and outputs, richer flexure models), whose equilibrium is found
 * by plain Newton from the answer instead of by a solve. The answer: q (nbase coordinates),
 * pose (3 noutputs) and compliance (9 noutputs) as fg_solve wrote them; T (rich->ndof x nbase,
 * row-major) maps q to the richer model's coordinates. Newton from T q (each stiffness positive
 * definite) until it is seen to converge: a state q_k that is an equilibrium to settings.tol
 * (T q itself, where the maps are exact) or whose step d_k is at most 0.1 of the step before; the richer pose is the
 * first-order pose(q_k) - J d_k, the richer compliance J K^-1 J^T at q_k (off by O(|d_k|); at
 * T q alone, off by O(|d_0|), measured too far off to be honest). Usually two evaluations of the
 * richer model. Per output j the differences dp_j = max(|r_j - r_j,rich| / scale[j], |angle_j -
 * angle_j,rich|) and dc_j = ||C_j - C_j,rich||_2 / ||C_j,rich||_2 (spectral norm, the larger of
 * the 2 x 2 position compliances' and the 3 x 3's with the angle row and column times scale[j])
 * become the estimates out[2 j] = factor dp_j + floors[j] and
 * out[2 j + 1] = factor dc_j + floors[noutputs] (factor: the margin of the model pair, floors:
 * the kernels' bounds, noutputs + 1 entries), and out[2 noutputs] = the largest of them (the whole
 * answer's), then out[2 noutputs + 1 ...] = the richer equilibrium's coordinates q_k - d_k
 * (rich->ndof entries: the curvature it gives is the stress's comparison); FG_ESTIMATE_UNDEFINED leaves out unspecified. FG_ESTIMATE_FAR: no convergence
 * within settings.max_iterations steps and within reach (largest change of a coordinate from
 * T q) of T q. Workspace: the richer problem's (fg_work_size, fg_iwork_size); nothing is kept
 * between calls. */
FG_API int fg_estimate(const fg_problem *rich, const fg_real *T, int nbase, const fg_real *q,
                       const fg_real *pose, const fg_real *compliance, const fg_real *scale,
                       const fg_real *floors, fg_real factor, fg_real reach, fg_real *work,
                       int *iwork, fg_real *out);

#ifdef __cplusplus
}
#endif

#endif /* FLEXGEN_CHAIN_SOLVER_H */
