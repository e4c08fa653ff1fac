/* The compiled chain solver's problem description and answer (see chain_solver.c).
 *
 * A scene is flattened into arrays by flexgen/compiled/plan.py; ctypes mirrors of these structs
 * live in flexgen/compiled/library.py and must stay in step with them.
 */
#ifndef FLEXGEN_CHAIN_SOLVER_H
#define FLEXGEN_CHAIN_SOLVER_H

#include <stddef.h>

/* a generated kernel: pose (3), J (3 x k), H (3 x k x k) of the tip in units of L */
typedef void (*fg_kernel)(const double *q, double *pose, double *J, double *H);
typedef int (*fg_range)(const double *q);

enum { FG_MODEL_KERNEL = 0, FG_MODEL_FEM = 1, FG_MODEL_PRB = 2 };
enum { FG_SOLVED = 0, FG_FALLBACK = 1, FG_MODEL_ERROR = 2 };

/* the kind of a critical event on the load path (fg_answer.critical_kind): the path ended at a
 * limit point and the solve snapped through, or it crossed a bifurcation and took the stable side
 * chosen for this reason (equilibrium.BUCKLING_SIDES[kind - 1] is its text) */
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
    int parent;           /* flexure whose tip frame carries this root (earlier in the list), -1: base */
    double at[3];         /* root frame in the parent frame: x, y, angle */
    double length;
    double gamma;         /* FG_MODEL_PRB: pin position */
    fg_kernel poly;       /* FG_MODEL_KERNEL: polynomial kernel (NULL: none) */
    fg_range in_range;    /* its range check */
    fg_kernel gauss;      /* Gauss kernel (NULL: none) */
    fg_range gauss_in_range;   /* its certified range */
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
    fg_potrf potrf;
    fg_potrs potrs;
    fg_getrf getrf;
    fg_getrs getrs;
    int min_size;         /* use them from this many coordinates on */
    fg_syev syev;         /* symmetric eigen-decomposition (NULL: the built-in Jacobi method) */
} fg_lapack;

typedef struct {
    int frame;            /* flexure whose tip frame carries the point, -1: base */
    double x, y;          /* in that frame */
} fg_point;

typedef struct {
    int ndof, nflex, npoints, nloads, ntendons, noutputs;
    const fg_flexure *flex;      /* nflex, every parent before its children */
    const fg_point *points;      /* npoints */
    const int *load_point;       /* nloads */
    const double *load;          /* 3 nloads: fx, fy, moment */
    const double *tension;       /* ntendons */
    const int *route_start;      /* ntendons: first entry in route */
    const int *route_len;        /* ntendons */
    const int *route;            /* point indices */
    const int *outputs;          /* noutputs point indices */
    const double *stiffness;     /* ndof: diagonal of the elastic energy's Hessian */
    double tol;                  /* relative residual of an equilibrium */
    double max_dq;               /* largest change of a coordinate along the path */
    int max_iterations;          /* Newton iterations per load step */
    int max_steps;               /* continuation steps */
    double initial_step, max_step, min_step;   /* load-factor steps of the continuation */
    fg_lapack lapack;
    const double *q0;            /* NULL, or a warm start: Newton at the full load from q0 */
} fg_problem;

typedef struct {
    double *q;            /* ndof: the equilibrium */
    double *pose;         /* 3 noutputs: world x, y, angle */
    double *compliance;   /* 9 noutputs: 3 x 3 d(x, y, angle)/d(fx, fy, moment) */
    double *stiffness;    /* ndof x ndof: the stiffness K at the equilibrium (NULL: not wanted) */
    double energy, residual;
    int iterations, stable;
    double *critical;     /* max_critical: the critical load factors met on the way, in order */
    int *critical_kind;   /* max_critical: FG_SNAP_THROUGH or FG_BUCKLING_* of each */
    int max_critical;     /* their capacity (0: the first critical event hands the solve back) */
    int ncritical;        /* how many were met */
    int *switched;        /* nflex (in fg_problem.flex order): 1 if that flexure's "auto" model
                           * used its Gauss kernel during the solve (SCMModel.switched); NULL:
                           * any kernel switch hands the solve back (FG_FALLBACK) */
} fg_answer;

size_t fg_work_size(const fg_problem *p);
size_t fg_iwork_size(const fg_problem *p);
int fg_solve(const fg_problem *p, double *work, int *iwork, fg_answer *out);

#endif /* FLEXGEN_CHAIN_SOLVER_H */
