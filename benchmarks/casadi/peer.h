/* The interface every contender of benchmarks/casadi_peer.py implements; harness.c drives it.
 *
 * A contender solves one scene: the scene's own loads and tensions (input 0) or all of them
 * times 1.01 (input 1). Cold: from the unloaded state (q = 0). Warm: from the contender's
 * previous answer, whatever input it was for. The contender keeps its state in its own
 * translation unit (this is benchmark code: globals are fine here).
 */
#ifndef PEER_H
#define PEER_H

#define PEER_MAX_OUT 4

typedef struct {
    int status;       /* 0: solved */
    int stable;       /* the stiffness at the answer is positive definite */
    int iterations;   /* Newton iterations of the solve */
    int calls;        /* kernel calls (CasADi) or chain evaluations (flexgen); -1: not known */
    int noutputs;
    int rows;         /* compliance rows and columns reported: 2 (x, y) or 3 (x, y, angle) */
    double pose[PEER_MAX_OUT][3];               /* world x, y, angle */
    double compliance[PEER_MAX_OUT][3][3];      /* d(x, y, angle)/d(fx, fy, moment) */
} peer_answer;

int peer_setup(void);                   /* 0: ready */
int peer_solve(int input, int warm);    /* 0: solved */
void peer_read(peer_answer *a);         /* the last solve's answer */
double peer_probe(void);                /* one number of the last answer (a checksum term) */

#endif
