/* The straight-tube scene both C examples use: a straight circular tube (radius 10, 32 spokes,
 * along x) and a rod of radius 2 held parallel to its axis at a known offset, with the closed
 * form of its contacts.
 *
 * The spokes sit at the middles of 32 sectors turned half a sector from +y, so the rod's side
 * facing +y meets the middle of a flat wall strip, at the 32-gon's apothem
 * a = R cos(pi / 32) from the axis: depth = r_rod - (a - offset).
 */
#ifndef STRAIGHT_TUBE_SCENE_H
#define STRAIGHT_TUBE_SCENE_H

#include "lumen.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>

/* The header's contact is proto's wire record, byte for byte, and so are the reply's and the
 * frame's headers. */
_Static_assert(sizeof(LumenContact) == 88, "LumenContact is 88 bytes");
_Static_assert(offsetof(LumenContact, sample) == 8, "sample at 8");
_Static_assert(offsetof(LumenContact, weights_b) == 32, "weights_b at 32");
_Static_assert(offsetof(LumenContact, point_a) == 48, "point_a at 48");
_Static_assert(offsetof(LumenContact, point_b) == 60, "point_b at 60");
_Static_assert(offsetof(LumenContact, normal) == 72, "normal at 72");
_Static_assert(offsetof(LumenContact, depth) == 84, "depth at 84");
_Static_assert(sizeof(LumenFrameHeader) == 40, "LumenFrameHeader is 40 bytes");
_Static_assert(sizeof(LumenContactsHeader) == 256, "LumenContactsHeader is 256 bytes");
_Static_assert(offsetof(LumenContactsHeader, detect_ns) == 32, "detect_ns at 32");
_Static_assert(offsetof(LumenContactsHeader, message) == 60, "message at 60");

#define RINGS 11
#define SPOKES 32
#define POINTS 7
#define PRECISION 4
#define SAMPLES ((POINTS - 1) * PRECISION + 1)
#define TUBE_R 10.0
#define ROD_R 2.0
#define SPACING 10.0
#define TOLERANCE 1e-3

static const char SPEC[] =
    "{\"bodies\":["
    "{\"name\":\"colon\",\"shape\":{\"tube\":{\"rings\":11,\"spokes\":32}}},"
    "{\"name\":\"scope\",\"shape\":{\"rod\":{\"points\":7,\"radius\":[2.0]}}}],"
    "\"pairs\":[{\"a\":\"scope\",\"b\":\"colon\",\"kind\":\"interior\"}],"
    "\"precision\":4}";

static const double PI = 3.14159265358979323846;

/* Prints the status and the library's message for a failed call; returns 1. */
static int failed(const char *what, LumenStatus status) {
    char message[512];
    lumen_last_error(message, sizeof message);
    fprintf(stderr, "%s: status %d: %s\n", what, (int)status, message);
    return 1;
}

/* The tube's rings (control point, then 32 spokes relative to it), then the rod's points at
 * `offset` along +y from the axis, from x = 20 to x = 80. */
static void fill_state(float *state, double offset) {
    float *p = state;
    for (int i = 0; i < RINGS; i++) {
        *p++ = (float)(i * SPACING);
        *p++ = 0.0f;
        *p++ = 0.0f;
        for (int k = 0; k < SPOKES; k++) {
            double angle = 2.0 * PI * (k + 0.5) / SPOKES;
            *p++ = 0.0f;
            *p++ = (float)(TUBE_R * cos(angle));
            *p++ = (float)(TUBE_R * sin(angle));
        }
    }
    for (int j = 0; j < POINTS; j++) {
        *p++ = (float)(20.0 + j * SPACING);
        *p++ = (float)offset;
        *p++ = 0.0f;
    }
}

/* Checks one frame's contacts against the closed form; returns the number of mismatches.
 * +y is angle 0, the middle of the sector between spokes 31 and 0 (spoke_b = 31). */
static int check(const LumenContact *contacts, size_t count, double offset) {
    double apothem = TUBE_R * cos(PI / SPOKES);
    double expected = ROD_R - (apothem - offset);
    size_t want = expected > 0.0 ? SAMPLES : 0;
    int bad = 0;
    if (count != want) {
        fprintf(stderr, "offset %.2f: %zu contacts, expected %zu\n", offset, count, want);
        bad++;
    }
    for (size_t i = 0; i < count; i++) {
        const LumenContact *c = &contacts[i];
        double normal_err = fabs(c->normal[0]) + fabs(c->normal[1] - 1.0) + fabs(c->normal[2]);
        if (fabs(c->depth - expected) > TOLERANCE || normal_err > TOLERANCE || fabs(c->point_b[1] - apothem) > TOLERANCE || c->pair != 0 ||
            c->kind != LUMEN_CONTACT_KIND_INTERIOR || c->body_a != 1 || c->body_b != 0 || c->sample != i || c->spoke_b != SPOKES - 1 ||
            (c->flags & LUMEN_FLAG_OUTSIDE)) {
            fprintf(stderr,
                    "offset %.2f: contact %zu: sample %u spoke %u kind %u flags %u depth %.6f (expected %.6f) normal (%.4f %.4f %.4f) wall y %.6f "
                    "(expected %.6f)\n",
                    offset, i, c->sample, c->spoke_b, c->kind, c->flags, c->depth, expected, c->normal[0], c->normal[1], c->normal[2], c->point_b[1],
                    apothem);
            bad++;
        }
    }
    return bad;
}

#endif
