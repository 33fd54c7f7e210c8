/* Lumen from C, through the daemon: opens a session of the straight-tube scene
 * (straight_tube_scene.h) on a running `lumen serve`, writes each frame in place, checks every
 * reply against the closed form, watches the session with an observer, sends one bad frame,
 * and rides out a daemon restart (the session reopens by itself). Exits non-zero on any
 * mismatch.
 *
 *   round_trip local PREFIX FRAMES [PACE_MS]     iceoryx2, `lumen serve --prefix PREFIX`
 *   round_trip zenoh ENDPOINT FRAMES [PACE_MS]   zenoh, e.g. tcp/127.0.0.1:7447
 *
 * It runs until FRAMES frames are checked (a minute at most), PACE_MS apart; frames lost while
 * the daemon is away are counted, not checked.
 *
 * Built and run by tests/e2e/c_client.rs against a real daemon; by hand:
 *   cargo build -p lumen-c && cargo run -p lumen-cli --bin lumen -- serve --prefix demo_ &
 *   cc -std=c11 -Iclient/c/include client/c/examples/round_trip.c target/debug/liblumen_c.a \
 *      -lpthread -ldl -lm -o round_trip && ./round_trip local demo_ 100
 */
#define _POSIX_C_SOURCE 200809L
#include "straight_tube_scene.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

static void sleep_ms(long ms) {
    struct timespec t = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&t, NULL);
}

/* One frame at `offset`: fill it in place, submit, wait for its reply and check it. Returns 0
 * for a checked reply, -1 for a frame lost to a daemon restart, else the mismatches. */
static int round_trip(LumenSession *session, double offset, int poison) {
    float *frame = NULL;
    size_t floats = 0;
    LumenStatus status = lumen_session_frame(session, &frame, &floats);
    if (status == LUMEN_STATUS_DISCONNECTED) {
        return -1; /* the daemon is gone; the next call tries to reopen */
    }
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_session_frame", status);
    }
    fill_state(frame, offset);
    if (poison) {
        frame[RINGS * (SPOKES + 1) * 3 + 4] = NAN; /* the rod's second point, y */
    }
    uint64_t number = 0;
    status = lumen_session_submit(session, &number);
    if (status == LUMEN_STATUS_DISCONNECTED) {
        return -1;
    }
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_session_submit", status);
    }
    LumenReply reply;
    status = lumen_session_contacts(session, 2000, &reply);
    if (status == LUMEN_STATUS_DISCONNECTED || status == LUMEN_STATUS_TIMEOUT) {
        return -1;
    }
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_session_contacts", status);
    }
    const LumenContactsHeader *h = reply.header;
    if (h->frame != number) {
        fprintf(stderr, "reply to frame %llu for frame %llu\n", (unsigned long long)h->frame, (unsigned long long)number);
        return 1;
    }
    if (poison) {
        printf("bad frame: status %u body %u index %u: %.*s\n", h->status, h->error_body, h->error_index, (int)h->message_len, (const char *)h->message);
        return h->status != LUMEN_FRAME_STATUS_NON_FINITE || h->error_body != 1 || h->error_index != 1 || reply.count != 0;
    }
    if (h->status != LUMEN_FRAME_STATUS_OK) {
        fprintf(stderr, "frame %llu: status %u: %.*s\n", (unsigned long long)number, h->status, (int)h->message_len, (const char *)h->message);
        return 1;
    }
    return check(reply.contacts, reply.count, offset);
}

/* Attaches an observer to the session, then sends frames until it has seen one frame and one
 * reply of them; returns the mismatches. */
static int observe(LumenClient *client, LumenSession *session, uint64_t id) {
    LumenObserver *observer = NULL;
    LumenStatus status = lumen_observer_open(client, id, &observer);
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_observer_open", status);
    }
    int frames = 0, replies = 0, bad = 0;
    for (int sent = 0; sent < 50 && (frames == 0 || replies == 0); sent++) {
        bad += round_trip(session, 8.5, 0) > 0;
        LumenObserved seen;
        while ((status = lumen_observer_next(observer, 50, &seen)) == LUMEN_STATUS_OK) {
            if (seen.kind == LUMEN_OBSERVED_KIND_FRAME) {
                frames++;
                bad += seen.floats != (size_t)(RINGS * (SPOKES + 1) * 3 + POINTS * 3) || seen.frame->session != id;
            } else if (seen.kind == LUMEN_OBSERVED_KIND_CONTACTS) {
                replies++;
                bad += seen.reply.header->session != id || check(seen.reply.contacts, seen.reply.count, 8.5);
            }
        }
        if (status != LUMEN_STATUS_TIMEOUT) {
            bad += failed("lumen_observer_next", status);
            break;
        }
    }
    printf("observer: %d frames, %d replies\n", frames, replies);
    if (lumen_observer_free(observer) != LUMEN_STATUS_OK || lumen_observer_free(observer) != LUMEN_STATUS_BAD_HANDLE) {
        fprintf(stderr, "an observer freed twice is not refused as a bad handle\n");
        bad++;
    }
    return bad + (frames == 0) + (replies == 0);
}

int main(int argc, char **argv) {
    if (argc < 4 || (strcmp(argv[1], "local") != 0 && strcmp(argv[1], "zenoh") != 0)) {
        fprintf(stderr, "usage: %s (local PREFIX | zenoh ENDPOINT) FRAMES [PACE_MS]\n", argv[0]);
        return 2;
    }
    int frames = atoi(argv[3]);
    long pace = argc > 4 ? atol(argv[4]) : 0;
    LumenClient *client = NULL;
    LumenStatus status = strcmp(argv[1], "local") == 0 ? lumen_client_local(argv[2], "round_trip.c", &client)
                                                       : lumen_client_zenoh(argv[2], NULL, "round_trip.c", &client);
    if (status != LUMEN_STATUS_OK) {
        return failed("connecting", status);
    }

    /* A spec the daemon refuses names what is wrong. */
    LumenSession *session = NULL;
    const char *bad_spec = "{\"bodies\":[],\"pairs\":[]}";
    status = lumen_session_open(client, bad_spec, strlen(bad_spec), &session);
    char message[512];
    lumen_last_error(message, sizeof message);
    printf("empty spec: status %d: %s\n", (int)status, message);
    int bad = status != LUMEN_STATUS_REFUSED || session != NULL;

    status = lumen_session_open(client, SPEC, strlen(SPEC), &session);
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_session_open", status);
    }
    uint64_t id = 0;
    lumen_session_id(session, &id);
    printf("session %llu\n", (unsigned long long)id);
    bad += lumen_session_frame(NULL, NULL, NULL) != LUMEN_STATUS_NULL_ARGUMENT;
    bad += lumen_session_submit((LumenSession *)client, NULL) != LUMEN_STATUS_BAD_HANDLE;

    /* Until FRAMES frames are checked; frames lost while the daemon is away don't count. */
    int checked = 0, lost = 0;
    time_t give_up = time(NULL) + 60;
    for (int k = 0; checked < frames && time(NULL) < give_up; k++) {
        double offset = k % 2 == 0 ? 8.5 : 9.0;
        int result = round_trip(session, offset, 0);
        if (result < 0) {
            lost++;
            sleep_ms(20);
            continue;
        }
        bad += result;
        checked++;
        if (checked == 1) {
            printf("frame %d: offset %.2f: checked\n", k, offset);
            bad += observe(client, session, id);
            /* A frame with a NaN gets an error status naming the body and index. */
            bad += round_trip(session, 8.5, 1);
        }
        if (checked % 10 == 0) {
            printf("progress %d\n", checked);
            fflush(stdout);
        }
        sleep_ms(pace);
    }
    uint64_t reconnects = 0;
    lumen_session_reconnects(session, &reconnects);
    printf("checked %d lost %d reconnects %llu\n", checked, lost, (unsigned long long)reconnects);
    status = lumen_session_close(session);
    if (status != LUMEN_STATUS_OK) {
        bad += failed("lumen_session_close", status);
    }
    lumen_client_free(client);
    if (bad > 0 || checked == 0) {
        fprintf(stderr, "%d mismatches, %d frames checked\n", bad, checked);
        return 1;
    }
    printf("ok\n");
    return 0;
}
