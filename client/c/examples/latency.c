/* Round-trip latency of the C client: the straight-tube scene (straight_tube_scene.h, 25
 * contacts a frame), FRAMES frames each copied into the frame in place, submitted, and its
 * reply awaited; prints the median and 99th percentile in microseconds. client/latency.sh runs
 * it beside the Rust and Python clients' twins, alternated, against one daemon.
 *
 *   latency (local PREFIX | zenoh ENDPOINT) FRAMES
 */
#define _POSIX_C_SOURCE 200809L
#include "straight_tube_scene.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_us(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e6 + t.tv_nsec / 1e3;
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s (local PREFIX | zenoh ENDPOINT) FRAMES\n", argv[0]);
        return 2;
    }
    int frames = atoi(argv[3]);
    LumenClient *client = NULL;
    LumenStatus status = strcmp(argv[1], "local") == 0 ? lumen_client_local(argv[2], "latency.c", &client)
                                                       : lumen_client_zenoh(argv[2], NULL, "latency.c", &client);
    if (status != LUMEN_STATUS_OK) {
        return failed("connecting", status);
    }
    LumenSession *session = NULL;
    if ((status = lumen_session_open(client, SPEC, strlen(SPEC), &session)) != LUMEN_STATUS_OK) {
        return failed("lumen_session_open", status);
    }
    size_t floats = RINGS * (SPOKES + 1) * 3 + POINTS * 3;
    float *state = malloc(floats * sizeof *state);
    double *times = malloc(frames * sizeof *times);
    if (state == NULL || times == NULL) {
        return 1;
    }
    fill_state(state, 8.5);
    for (int k = -100; k < frames; k++) { /* 100 frames of warm-up */
        double start = now_us();
        float *frame = NULL;
        size_t n = 0;
        LumenReply reply;
        if ((status = lumen_session_frame(session, &frame, &n)) != LUMEN_STATUS_OK || n != floats) {
            return failed("lumen_session_frame", status);
        }
        memcpy(frame, state, floats * sizeof *state);
        if ((status = lumen_session_submit(session, NULL)) != LUMEN_STATUS_OK) {
            return failed("lumen_session_submit", status);
        }
        if ((status = lumen_session_contacts(session, 1000, &reply)) != LUMEN_STATUS_OK) {
            return failed("lumen_session_contacts", status);
        }
        if (reply.count != SAMPLES || (k == -100 && check(reply.contacts, reply.count, 8.5) != 0)) {
            fprintf(stderr, "%zu contacts, expected %d against the closed form\n", reply.count, SAMPLES);
            return 1;
        }
        if (k >= 0) {
            times[k] = now_us() - start;
        }
    }
    qsort(times, frames, sizeof *times, by_value);
    printf("c: p50 %.1f us p99 %.1f us (%d frames)\n", times[frames / 2], times[frames * 99 / 100], frames);
    lumen_session_close(session);
    lumen_client_free(client);
    free(state);
    free(times);
    return 0;
}
