/*
 * ptsa_twin.c -- an independent C11 implementation of the PTSA tick, written from
 * ptsa-core/ARITHMETIC.md alone. It reads a golden input (tests/golden/NAME.in) on stdin and
 * writes the golden output on stdout; `cargo xtask ci` builds it with the system C compiler
 * and checks it against every tests/golden/NAME.out. Agreement shows that the written
 * specification, not only the Rust code, fixes every bit.
 *
 * Portable C: no signed left shifts (multiplications instead) and an explicit floor shift
 * for negative values (C leaves >> of negative numbers implementation-defined).
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define R ((int32_t)1 << 24)          /* ramp amplitude, comparator LSB */
#define INTEG_LIMIT ((int64_t)1 << 40) /* integrator clamp, 2^-16 comparator LSB */

typedef struct {
    int n;          /* ticks per cycle, power of two */
    int32_t b0, b1, a1, ki;
    uint32_t gate;  /* preset T */
    bool shaping;
} config_t;

typedef struct {
    int32_t e_prev, lead;
    int64_t integ;
    int32_t carry;
    uint32_t ticks, pulses;
    bool switched;
    int32_t latched;
    uint16_t n;
    uint32_t t0, p0;
    uint32_t sat_integ, sat_out, sat_carry;
} state_t;

/* floor(x / 2^s) for any sign */
static int64_t asr(int64_t x, int s) { return x >= 0 ? x >> s : ~((~x) >> s); }

static int64_t clamp64(int64_t x, int64_t lim, uint32_t *sat) {
    if (x > lim) { (*sat)++; return lim; }
    if (x < -lim) { (*sat)++; return -lim; }
    return x;
}

/* One tick; returns 1 for positive polarity. *cycle = n or -1; *gate_p = pulses or -1. */
static int tick(const config_t *c, state_t *s, int16_t x, int *cycle, int64_t *gate_p) {
    int32_t h = R / c->n;
    int64_t e = x;
    /* 2. lead */
    int64_t acc = (int64_t)c->b0 * e + (int64_t)c->b1 * s->e_prev + (int64_t)c->a1 * s->lead;
    int64_t lead = asr(acc + ((int64_t)1 << 15), 16);
    s->lead = (int32_t)lead;
    s->e_prev = (int32_t)e;
    /* 3. integrator */
    s->integ = clamp64(s->integ + (int64_t)c->ki * e, INTEG_LIMIT, &s->sat_integ);
    /* 4. summing junction */
    int32_t u = (int32_t)clamp64(lead + asr(s->integ, 16), R, &s->sat_out);
    /* 5. ramp and quantizer */
    uint32_t k = s->ticks & (uint32_t)(c->n - 1);
    int32_t v = u + s->carry;
    int32_t r = h * (c->n - 1 - 2 * (int32_t)k);
    if (!s->switched && v + r < 0) {
        s->switched = true;
        s->latched = v;
        s->n = (uint16_t)k;
    }
    /* 6. output */
    int positive = !s->switched;
    s->pulses += (uint32_t)positive;
    s->ticks += 1;
    /* 7. end of cycle */
    *cycle = -1;
    if ((s->ticks & (uint32_t)(c->n - 1)) == 0) {
        if (positive) { s->latched = v; s->n = (uint16_t)c->n; }
        if (c->shaping) {
            int32_t y = h * (2 * (int32_t)s->n - c->n);
            s->carry = (int32_t)clamp64((int64_t)s->latched - y, h, &s->sat_carry);
        }
        *cycle = s->n;
        s->switched = false;
    }
    /* 8. end of gate */
    *gate_p = -1;
    if (s->ticks - s->t0 == c->gate) {
        *gate_p = s->pulses - s->p0;
        s->t0 = s->ticks;
        s->p0 = s->pulses;
    }
    return positive;
}

static uint64_t fnv(uint64_t h, const void *p, size_t len) {
    const unsigned char *b = p;
    for (size_t i = 0; i < len; i++) { h ^= b[i]; h *= 0x100000001b3ULL; }
    return h;
}

#define LE(h, v, bytes) do { uint64_t t_ = (uint64_t)(v); unsigned char b_[8]; \
    for (int i_ = 0; i_ < (bytes); i_++) b_[i_] = (unsigned char)(t_ >> (8 * i_)); \
    h = fnv(h, b_, (bytes)); } while (0)

static uint64_t digest(const state_t *s) {
    uint64_t h = 0xcbf29ce484222325ULL;
    LE(h, (uint32_t)s->e_prev, 4); LE(h, (uint32_t)s->lead, 4); LE(h, (uint64_t)s->integ, 8);
    LE(h, (uint32_t)s->carry, 4); LE(h, s->ticks, 4); LE(h, s->pulses, 4);
    LE(h, s->switched ? 1 : 0, 1); LE(h, (uint32_t)s->latched, 4); LE(h, s->n, 2);
    LE(h, s->t0, 4); LE(h, s->p0, 4);
    LE(h, s->sat_integ, 4); LE(h, s->sat_out, 4); LE(h, s->sat_carry, 4);
    return h;
}

static void end_run(const state_t *s) {
    printf("end ticks=%" PRIu32 " pulses=%" PRIu32 " sat=%" PRIu32 ",%" PRIu32 ",%" PRIu32
           " digest=%016" PRIx64 "\n",
           s->ticks, s->pulses, s->sat_integ, s->sat_out, s->sat_carry, digest(s));
}

int main(void) {
    char line[256];
    config_t c;
    state_t s;
    bool running = false;
    long line_no = 0;
    while (fgets(line, sizeof line, stdin)) {
        line_no++;
        char *p = line;
        while (*p == ' ' || *p == '\t') p++;
        if (*p == '#' || *p == '\n' || *p == '\r' || *p == 0) continue;
        if (strncmp(p, "config", 6) == 0) {
            int shaping;
            if (sscanf(p, "config n=%d b0=%" SCNd32 " b1=%" SCNd32 " a1=%" SCNd32 " ki=%" SCNd32
                          " gate=%" SCNu32 " shaping=%d",
                       &c.n, &c.b0, &c.b1, &c.a1, &c.ki, &c.gate, &shaping) != 7) {
                fprintf(stderr, "line %ld: bad config line\n", line_no);
                return 2;
            }
            c.shaping = shaping != 0;
            if (running) end_run(&s);
            memset(&s, 0, sizeof s);
            running = true;
            continue;
        }
        if (!running) { fprintf(stderr, "line %ld: sample before config\n", line_no); return 2; }
        long x = strtol(p, NULL, 10);
        int cycle;
        int64_t gate_p;
        int pos = tick(&c, &s, (int16_t)x, &cycle, &gate_p);
        putchar(pos ? '+' : '-');
        if (cycle >= 0) printf(" c%d", cycle);
        if (gate_p >= 0) printf(" g%" PRId64 "/%" PRIu32, gate_p, c.gate);
        putchar('\n');
    }
    if (running) end_run(&s);
    return 0;
}
