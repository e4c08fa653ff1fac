/* A controller-side use of the compiled chain solver: the tendon-driven two-link finger of
 * examples/two_link_finger.toml (two 3-mode smooth curvature flexures, a palm, a middle link and a
 * fingertip; a flexor tendon from the palm through the middle link to the fingertip; a contact
 * force on the fingertip pad), filled into an fg_problem by hand the way flexgen/problem.py fills
 * it from the scene, and solved in one fg_solve call per control cycle: equilibrium, pad poses
 * and pad compliances. No heap, no globals: the workspace is a fixed-size stack array, checked
 * against fg_work_size / fg_iwork_size at start.
 *
 * Each flexure uses the kernel pair of the scm model's kernel "auto": the polynomial kernel scm3
 * within its range, the Gauss kernel scm3_gauss25 past it. When fg_solve finds no equilibrium
 * (FG_NO_EQUILIBRIUM: e.g. no path to the full load) it says why (answer.failure, at
 * answer.failure_load_factor); a real controller then keeps its last answer.
 *
 * Build:  gcc -std=c99 -Wall -Wextra -Werror -pedantic -O2 -I../../flexgen/compiled \
 *             -I../../generated/c finger_controller.c ../../flexgen/compiled/chain_solver.c \
 *             ../../generated/c/scm3.c ../../generated/c/scm3_gauss25.c -lm -o finger_controller
 * Run:    ./finger_controller [tension [pad_force_y]]     (defaults: 10 N and -0.2 N, the TOML's)
 * Prints one JSON object: status, converged, q (6), the poses (x, y in m; angle in rad) and 2x2
 * compliances (m/N) of middle.pad and fingertip.pad, the Newton iterations and the mean time of
 * one fg_solve in microseconds; or status "no_equilibrium" with the failure (FG_FAIL_*) and its
 * load factor. Exit status: 0 solved, 3 no equilibrium, 4 model error, 1 workspace too small,
 * 2 bad arguments.
 */
#define _POSIX_C_SOURCE 199309L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "chain_solver.h"
#include "scm3.h"
#include "scm3_gauss25.h"

#define NFLEX 2
#define NDOF (NFLEX * SCM3_N)
#define NPOINTS 5           /* fingertip.pad, base.r0, middle.hole, fingertip.anchor, middle.pad */
#define NROUTE 3
#define NOUTPUTS 2
#ifndef WORK_MAX
#define WORK_MAX 4096       /* doubles; fg_work_size is under 1000 for this finger */
#endif
#ifndef IWORK_MAX
#define IWORK_MAX 64        /* ints; fg_iwork_size is NDOF + 1 */
#endif
#define TIMING_SECONDS 0.2

/* Everything the fg_problem points into; it lives on main's stack. */
typedef struct {
    fg_flexure flex[NFLEX];
    fg_point points[NPOINTS];
    int load_point[1];
    double load[3];
    double tension[1];
    int route_start[1], route_len[1], route[NROUTE];
    int outputs[NOUTPUTS];
    double stiffness[NDOF];
    fg_problem problem;
} Finger;

/* One 3-mode smooth curvature flexure of kernel "auto", its root at `at` in the tip frame of
 * flexure `parent` (-1: the palm), and its diagonal energy Hessian EI/L * ENERGY_WEIGHTS. */
static void scm3_flexure(Finger *f, int i, int parent, double x, double y, double angle,
                         double length, double E, double width, double thickness)
{
    /* U = EI/(2L) sum_n w_n q_n^2 with w_n = 1/(2n + 1): ENERGY_WEIGHTS of generated/numpy/scm3.py
     * (the C header has no macro for them); tests/test_finger_controller_example.py checks these
     * three values against flexgen.kernels.load_numpy("scm3").ENERGY_WEIGHTS. */
    const double energy_weights[SCM3_N] = {1.0, 0.3333333333333333, 0.2};
    const double EI = E * width * pow(thickness, 3.0) / 12.0;   /* as flexgen/scene.py */
    fg_flexure *fl = &f->flex[i];
    int n;
    fl->kind = FG_MODEL_KERNEL;
    fl->ndof = SCM3_N;
    fl->offset = i * SCM3_N;
    fl->parent = parent;
    fl->at[0] = x;
    fl->at[1] = y;
    fl->at[2] = angle;
    fl->length = length;
    fl->gamma = 0.0;
    fl->poly = scm3_evaluate;
    fl->in_range = scm3_in_range;
    fl->gauss = scm3_gauss25_evaluate;
    fl->gauss_in_range = scm3_gauss25_in_range;
    for (n = 0; n < SCM3_N; ++n)
        f->stiffness[fl->offset + n] = EI / length * energy_weights[n];
}

static void set_point(fg_point *p, int frame, double x, double y)
{
    p->frame = frame;
    p->x = x;
    p->y = y;
}

/* the solver settings: the defaults of flexgen/settings.py (SolverSettings), field by field
 * (tests/test_finger_controller_example.py checks that they are) */
static void default_settings(fg_settings *s)
{
    s->tol = 1e-12;
    s->max_dq = 0.5;
    s->max_iterations = 50;
    s->max_steps = 500;
    s->initial_step = 0.1;
    s->max_step = 0.25;
    s->min_step = 1e-05;
    s->polish_target = 1e-14;
    s->polish_steps = 3;
    s->direct_max_iterations = 12;
    s->direct_correction = 0.2;
    s->direct_samples = 3;
    s->stagnation_after = 8;
    s->stagnation_ratio = 0.5;
    s->stagnation_lag = 6;
    s->armijo = 0.0001;
    s->line_search_halvings = 30;
    s->expansion_doublings = 40;
    s->eigenvalue_floor = 1e-10;
    s->roundoff_tol = 1e-13;
    s->bifurcation_threshold = 1e-06;
    s->bracket_tol = 1e-13;
    s->bracket_iterations = 100;
    s->bracket_clamp = 0.01;
    s->descent_eps = 0.001;
    s->descent_iteration_factor = 20;
    s->tie_tol = 1e-09;
    s->fast_iterations = 3;
    s->fast_growth = 2.0;
    s->moderate_iterations = 6;
    s->moderate_growth = 1.2;
    s->step_shrink = 0.5;
    s->lapack_min_size = 32;
    s->bend_samples = 65;
    s->circle_tol = 1e-14;
}

/* The finger of examples/two_link_finger.toml with this tendon tension and pad force (y). */
static void finger_setup(Finger *f, double tension, double pad_fy)
{
    fg_problem *p = &f->problem;
    memset(f, 0, sizeof *f);        /* any field not set below: 0 / NULL */
    /* flexures in body order: proximal on the palm; distal at middle.joint, i.e. in the frame
     * of the middle link, which is the proximal flexure's tip frame (flexure 0) */
    scm3_flexure(f, 0, -1, 0.0, 0.0, 0.0, 0.020, 200e9, 0.010, 0.00025);
    scm3_flexure(f, 1, 0, 0.045, 0.0, 0.0, 0.015, 200e9, 0.010, 0.00020);
    /* points in the order flexgen/problem.py lists them (loads, tendon routes, outputs, each
     * point once), each on the flexure frame that carries its link: middle -> proximal (0),
     * fingertip -> distal (1), base -> -1 */
    set_point(&f->points[0], 1, 0.015, -0.004);    /* fingertip.pad */
    set_point(&f->points[1], -1, -0.010, 0.004);   /* base.r0 */
    set_point(&f->points[2], 0, 0.002, 0.004);     /* middle.hole */
    set_point(&f->points[3], 1, 0.004, 0.004);     /* fingertip.anchor */
    set_point(&f->points[4], 0, 0.020, -0.004);    /* middle.pad */
    f->load_point[0] = 0;                          /* the contact force on fingertip.pad */
    f->load[0] = 0.0;
    f->load[1] = pad_fy;
    f->load[2] = 0.0;
    f->tension[0] = tension;                       /* base.r0 -> middle.hole -> fingertip.anchor */
    f->route_start[0] = 0;
    f->route_len[0] = NROUTE;
    f->route[0] = 1;
    f->route[1] = 2;
    f->route[2] = 3;
    f->outputs[0] = 4;                             /* middle.pad */
    f->outputs[1] = 0;                             /* fingertip.pad */

    p->ndof = NDOF;
    p->nflex = NFLEX;
    p->npoints = NPOINTS;
    p->nloads = 1;
    p->ntendons = 1;
    p->noutputs = NOUTPUTS;
    p->flex = f->flex;
    p->points = f->points;
    p->load_point = f->load_point;
    p->load = f->load;
    p->tension = f->tension;
    p->route_start = f->route_start;
    p->route_len = f->route_len;
    p->route = f->route;
    p->outputs = f->outputs;
    p->stiffness = f->stiffness;
    default_settings(&p->settings);
    p->lapack.potrf = NULL;         /* built-in factorizations: as fast for 6 coordinates */
    p->lapack.potrs = NULL;
    p->lapack.getrf = NULL;
    p->lapack.getrs = NULL;
    p->lapack.syev = NULL;
    p->q0 = NULL;                   /* from the unloaded state (no warm start) */
}

static int parse(const char *text, double *value)
{
    char *end;
    *value = strtod(text, &end);
    return end != text && *end == '\0' && isfinite(*value);
}

static double seconds_since(const struct timespec *t0)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)(t.tv_sec - t0->tv_sec) + 1e-9 * (double)(t.tv_nsec - t0->tv_nsec);
}

static void print_point(const char *name, const double *pose, const double *C, int last)
{
    /* C: the 3x3 compliance d(x, y, angle)/d(fx, fy, moment); the 2x2 position block is printed */
    printf("\"%s\": {\"pose\": [%.17g, %.17g, %.17g], "
           "\"compliance\": [[%.17g, %.17g], [%.17g, %.17g]]}%s",
           name, pose[0], pose[1], pose[2], C[0], C[1], C[3], C[4], last ? "" : ", ");
}

int main(int argc, char **argv)
{
    Finger finger;
    double work[WORK_MAX];
    int iwork[IWORK_MAX];
    double q[NDOF], pose[3 * NOUTPUTS], compliance[9 * NOUTPUTS];
    fg_answer answer;
    double tension = 10.0, pad_fy = -0.2, elapsed = 0.0;
    struct timespec t0;
    long solves = 0;
    int status, i;

    if (argc > 3 || (argc > 1 && !parse(argv[1], &tension))
        || (argc > 2 && !parse(argv[2], &pad_fy))) {
        fprintf(stderr, "usage: %s [tension [pad_force_y]]   (N; defaults 10 -0.2)\n", argv[0]);
        return 2;
    }
    finger_setup(&finger, tension, pad_fy);
    if (fg_work_size(&finger.problem) > WORK_MAX || fg_iwork_size(&finger.problem) > IWORK_MAX) {
        fprintf(stderr, "%s: workspace too small: need %lu doubles and %lu ints, have %d and %d\n",
                argv[0], (unsigned long)fg_work_size(&finger.problem),
                (unsigned long)fg_iwork_size(&finger.problem), WORK_MAX, IWORK_MAX);
        return 1;
    }
    memset(&answer, 0, sizeof answer);      /* NULL for every output not wanted (stiffness) */
    answer.q = q;
    answer.pose = pose;
    answer.compliance = compliance;

    status = fg_solve(&finger.problem, work, iwork, &answer);
    if (status == FG_NO_EQUILIBRIUM) {
        /* a real controller keeps its last answer */
        printf("{\"status\": \"no_equilibrium\", \"converged\": false, \"failure\": %d, "
               "\"load_factor\": %.17g}\n", answer.failure, answer.failure_load_factor);
        return 3;
    }
    if (status != FG_SOLVED) {
        printf("{\"status\": \"model_error\", \"converged\": false}\n");
        return 4;
    }

    /* the cost of one control cycle: repeated solves of the same problem for about 0.2 s */
    clock_gettime(CLOCK_MONOTONIC, &t0);
    do {
        if (fg_solve(&finger.problem, work, iwork, &answer) != FG_SOLVED)
            break;
        ++solves;
        elapsed = seconds_since(&t0);
    } while (elapsed < TIMING_SECONDS);
    elapsed = seconds_since(&t0);

    printf("{\"status\": \"solved\", \"converged\": true, \"q\": [");
    for (i = 0; i < NDOF; ++i)
        printf("%.17g%s", q[i], i + 1 < NDOF ? ", " : "");
    printf("], \"points\": {");
    print_point("middle.pad", pose, compliance, 0);
    print_point("fingertip.pad", pose + 3, compliance + 9, 1);
    printf("}, \"iterations\": %d, \"us_per_solve\": %.6g}\n", answer.iterations,
           solves > 0 ? 1e6 * elapsed / (double)solves : -1.0);
    return 0;
}
