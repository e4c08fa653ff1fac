/* The timing program of one contender of benchmarks/casadi_peer.py (linked with its peer_*).
 *
 *   harness answer          one JSON line: the cold answer at input 0, then the warm answer at
 *                           input 1 (from input 0's) and again at input 0 (from input 1's)
 *   harness time MODE N     MODE cold or warm: N solves after N/10 + 1 untimed ones; prints
 *                           "<mean ns per solve> <checksum>". Warm solves alternate between
 *                           input 1 and input 0, each from the previous answer.
 *
 * Compiled like every contender: gcc -O2 -std=c99 (no -ffast-math, no -march), each source its
 * own translation unit, no LTO; every solve's answer feeds a checksum written to a volatile sink.
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "peer.h"

volatile double harness_sink;

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static void print_answer(const char *key, int status, const char *sep)
{
    peer_answer a;
    int k, i, j;
    memset(&a, 0, sizeof a);
    peer_read(&a);
    printf("\"%s\": {\"status\": %d, \"stable\": %d, \"iterations\": %d, \"calls\": %d, "
           "\"points\": [", key, status, a.stable, a.iterations, a.calls);
    for (k = 0; k < a.noutputs; ++k) {
        printf("{\"pose\": [%.17g, %.17g, %.17g], \"compliance\": [", a.pose[k][0], a.pose[k][1],
               a.pose[k][2]);
        for (i = 0; i < a.rows; ++i) {
            printf("[");
            for (j = 0; j < a.rows; ++j)
                printf("%.17g%s", a.compliance[k][i][j], j + 1 < a.rows ? ", " : "");
            printf("]%s", i + 1 < a.rows ? ", " : "");
        }
        printf("]}%s", k + 1 < a.noutputs ? ", " : "");
    }
    printf("]}%s", sep);
}

static int answer(void)
{
    printf("{");
    print_answer("cold", peer_solve(0, 0), ", ");
    print_answer("warm", peer_solve(1, 1), ", ");
    print_answer("warm_back", peer_solve(0, 1), "}\n");
    return 0;
}

static int time_solves(int warm, long n)
{
    double sum = 0.0, t0, t1;
    long k, step = 0;   /* warm: solve number `step` is at input step & 1 */
    int bad = peer_solve(0, 0);
    for (k = 0; k < n / 10 + 1; ++k) {
        ++step;
        bad |= peer_solve(warm ? (int)(step & 1) : 0, warm);
        sum += peer_probe();
    }
    t0 = now_ns();
    for (k = 0; k < n; ++k) {
        ++step;
        bad |= peer_solve(warm ? (int)(step & 1) : 0, warm);
        sum += peer_probe();
    }
    t1 = now_ns();
    harness_sink = sum;
    if (bad) {
        fprintf(stderr, "harness: a solve failed\n");
        return 1;
    }
    printf("%.6f %.17g\n", (t1 - t0) / (double)n, harness_sink);
    return 0;
}

int main(int argc, char **argv)
{
    if (peer_setup() != 0) {
        fprintf(stderr, "harness: setup failed\n");
        return 1;
    }
    if (argc == 2 && strcmp(argv[1], "answer") == 0)
        return answer();
    if (argc == 4 && strcmp(argv[1], "time") == 0
        && (strcmp(argv[2], "cold") == 0 || strcmp(argv[2], "warm") == 0) && atol(argv[3]) > 0)
        return time_solves(strcmp(argv[2], "warm") == 0, atol(argv[3]));
    fprintf(stderr, "usage: %s answer | time cold|warm N\n", argv[0]);
    return 2;
}
