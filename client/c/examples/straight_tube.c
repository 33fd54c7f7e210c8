/* Lumen from C, embedded: runs the detector on three frames of the straight-tube scene
 * (straight_tube_scene.h) and checks every contact against the closed form; exits non-zero on
 * any mismatch.
 *
 * Built and run by client/c/tests/c_example.rs; by hand, from the repository root:
 *   cargo build -p lumen-c
 *   cc -std=c11 -Iclient/c/include client/c/examples/straight_tube.c target/debug/liblumen_c.a \
 *      -lpthread -ldl -lm -o straight_tube && ./straight_tube
 */
#include "straight_tube_scene.h"

#include <stdlib.h>
#include <string.h>

int main(void) {
    LumenDetector *detector = NULL;
    LumenStatus status = lumen_detector_new(SPEC, strlen(SPEC), &detector);
    if (status != LUMEN_STATUS_OK) {
        return failed("lumen_detector_new", status);
    }
    size_t floats = 0;
    status = lumen_detector_floats(detector, &floats);
    if (status != LUMEN_STATUS_OK) {
        lumen_detector_free(detector);
        return failed("lumen_detector_floats", status);
    }
    float *state = malloc(floats * sizeof *state);
    if (state == NULL || floats != (size_t)(RINGS * (SPOKES + 1) * 3 + POINTS * 3)) {
        fprintf(stderr, "state of %zu floats\n", floats);
        lumen_detector_free(detector);
        free(state);
        return 1;
    }

    /* Pressing the wall, pressing harder, then on the axis (clear of the wall). */
    const double offsets[] = {8.5, 9.0, 0.0};
    int bad = 0;
    for (int frame = 0; frame < 3; frame++) {
        fill_state(state, offsets[frame]);
        const LumenContact *contacts = NULL;
        size_t count = 0;
        status = lumen_detector_detect(detector, state, floats, &contacts, &count);
        if (status != LUMEN_STATUS_OK) {
            bad += failed("lumen_detector_detect", status);
            break;
        }
        double depth = count > 0 ? contacts[0].depth : 0.0;
        printf("frame %d: offset %.2f: %zu contacts, first depth %.4f (closed form %.4f)\n", frame, offsets[frame], count, depth,
               ROD_R - (TUBE_R * cos(PI / SPOKES) - offsets[frame]));
        bad += check(contacts, count, offsets[frame]);
    }

    /* A state one float short is refused, and says why. */
    const LumenContact *contacts = NULL;
    size_t count = 0;
    status = lumen_detector_detect(detector, state, floats - 1, &contacts, &count);
    char message[256];
    lumen_last_error(message, sizeof message);
    if (status != LUMEN_STATUS_BAD_STATE || contacts != NULL || count != 0) {
        fprintf(stderr, "short state: status %d, %zu contacts\n", (int)status, count);
        bad++;
    } else {
        printf("short state refused: %s\n", message);
    }

    lumen_detector_free(detector);
    free(state);
    if (bad > 0) {
        fprintf(stderr, "%d mismatches\n", bad);
        return 1;
    }
    printf("ok\n");
    return 0;
}
