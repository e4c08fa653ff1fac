/* flexgen's solver core as a contender: fg_solve on the fg_problem that flexgen.Solver fills
 * for the scene (peer_fgcore.h, written by benchmarks/casadi_peer.py), with the built-in
 * factorizations (no LAPACK, as examples/controller/finger_controller.c). Cold: q0 = NULL (the
 * core starts from the unloaded state); warm: q0 = the previous answer's q (the core's warm
 * start: Newton at the full load from q0, else from the unloaded state). */
#include <string.h>

#include "peer.h"
#include "peer_fgcore.h"

#define WORK_MAX 8192
#define IWORK_MAX 256

static fg_problem problem;
static double work[WORK_MAX];
static int iwork[IWORK_MAX];
static double q[2][PEER_NDOF];     /* the last answer's q and the next one's */
static int last;                   /* q[last] is the last answer's */
static double pose[3 * PEER_NOUT], compliance[9 * PEER_NOUT];
static fg_answer answer;

int peer_setup(void)
{
    memset(&problem, 0, sizeof problem);
    problem.ndof = PEER_NDOF;
    problem.nflex = PEER_NFLEX;
    problem.npoints = PEER_NPOINTS;
    problem.nloads = PEER_NLOADS;
    problem.ntendons = PEER_NTENDONS;
    problem.noutputs = PEER_NOUT;
    problem.flex = peer_flex;
    problem.points = peer_points;
    problem.load_point = peer_load_point;
    problem.load = peer_load[0];
    problem.tension = peer_tension[0];
    problem.route_start = peer_route_start;
    problem.route_len = peer_route_len;
    problem.route = peer_route;
    problem.outputs = peer_outputs;
    problem.stiffness = peer_stiffness;
    peer_settings(&problem.settings);
    memset(&answer, 0, sizeof answer);
    answer.pose = pose;
    answer.compliance = compliance;
    if (fg_work_size(&problem) > WORK_MAX || fg_iwork_size(&problem) > IWORK_MAX)
        return 1;
    return 0;
}

int peer_solve(int input, int warm)
{
    int status;
    problem.load = peer_load[input];
    problem.tension = peer_tension[input];
    problem.q0 = warm ? q[last] : NULL;
    answer.q = q[1 - last];
    status = fg_solve(&problem, work, iwork, &answer);
    if (status == FG_SOLVED)
        last = 1 - last;
    return status;
}

void peer_read(peer_answer *a)
{
    int o, i, j;
    a->stable = answer.stable;
    a->iterations = answer.iterations;
    a->calls = answer.evaluations;
    a->noutputs = PEER_NOUT;
    a->rows = 3;
    for (o = 0; o < PEER_NOUT; ++o) {
        for (i = 0; i < 3; ++i)
            a->pose[o][i] = pose[3 * o + i];
        for (i = 0; i < 3; ++i)
            for (j = 0; j < 3; ++j)
                a->compliance[o][i][j] = compliance[9 * o + 3 * i + j];
    }
}

double peer_probe(void)
{
    return pose[0] + compliance[9 * PEER_NOUT - 1];
}
