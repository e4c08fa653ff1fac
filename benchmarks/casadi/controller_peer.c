/* flexgen's scene controller as a contender: NAME_solve of `flexgen generate --scene SCENE
 * --prefix NAME` (compiled with -DPEER_PREFIX=NAME -DPEER_UPPER=<NAME in capitals>
 * '-DPEER_HEADER="NAME.h"', and -DPEER_CALLS=<the outputs' field counting evaluations> if
 * there is one). Cold: state.solved = 0 before each call, as docs/controller.md tells a
 * controller to ask for a cold solve (clearing the whole state, its solver scratch included,
 * would time a 5 to 14 kB memset too); warm: the state kept from the previous call. Input 0 is
 * NAME_inputs_default, input 1 every load and tension of it times 1.01. */
#include <string.h>

#include "peer.h"
#include PEER_HEADER

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define NAME(x) CAT(PEER_PREFIX, x)
#define UPPER(x) CAT(PEER_UPPER, x)
#define NOUT UPPER(_NOUTPUTS)

static NAME(_inputs) inputs[2];
static NAME(_state) state;
static NAME(_outputs) out;

int peer_setup(void)
{
    int i, j;
    NAME(_inputs_default)(&inputs[0]);
    inputs[1] = inputs[0];
    for (i = 0; i < UPPER(_NLOADS); ++i)
        for (j = 0; j < 3; ++j)
            inputs[1].load[i][j] *= 1.01;
    for (i = 0; i < UPPER(_NTENDONS); ++i)
        inputs[1].tension[i] *= 1.01;
    memset(&state, 0, sizeof state);
    return NOUT <= PEER_MAX_OUT ? 0 : 1;
}

int peer_solve(int input, int warm)
{
    if (!warm)
        state.solved = 0;
    return NAME(_solve)(&inputs[input], &state, &out);
}

void peer_read(peer_answer *a)
{
    int o, i, j;
    a->stable = out.stable;
    a->iterations = out.iterations;
#ifdef PEER_CALLS
    a->calls = out.PEER_CALLS;
#else
    a->calls = -1;
#endif
    a->noutputs = NOUT;
    a->rows = 3;
    for (o = 0; o < NOUT; ++o) {
        for (i = 0; i < 3; ++i)
            a->pose[o][i] = out.pose[o][i];
        for (i = 0; i < 3; ++i)
            for (j = 0; j < 3; ++j)
                a->compliance[o][i][j] = out.compliance[o][i][j];
    }
}

double peer_probe(void)
{
    return out.pose[0][0] + out.compliance[NOUT - 1][2][2];
}
