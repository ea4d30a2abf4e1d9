/*
 * static_loop.c -- a plain C11 implementation of `ptsa static`'s loop, for comparing speeds
 * (`ptsa bench --compare-c` builds it with the system `cc -std=c11 -O2` and runs it).
 *
 * Per tick, exactly as ClosedLoop::run_static_fast in ptsa-host-sim/src/sim.rs:
 *   1. ADC: code = (int16)(sat_u16(y * gain + (offset + 32768.5) + noise * N(0,1)) ^ 0x8000),
 *      the normal draw from the same wyrand-indexed 4096-entry table;
 *   2. the PTSA tick of ptsa-core/c-twin/ptsa_twin.c (ARITHMETIC.md; h = R/N precomputed);
 *   3. the exact ZOH step x' = Phi x + add[region][polarity] with Phi's structural zeros,
 *      the free region unless |theta| is beyond the stop, with the polarity decided at the
 *      previous tick (one interval of computation delay).
 * The matrices, the ADC constants, the noise table and the seed's generator state come
 * from the Rust side on stdin (`ClosedLoop::c_static_params`), so both loops compute the
 * same numbers: the program prints the pulse count and the final plant state (IEEE bits)
 * of each run, and the Rust side checks them bit for bit.
 *
 * Usage: static_loop SETTLE TICKS RUNS < params; prints one line per run:
 *   "rate=<ticks/s> pulses=<P over the TICKS gate> x=<the 4 state values' bits in hex>".
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define R ((int32_t)1 << 24)          /* ramp amplitude, comparator LSB */
#define INTEG_LIMIT ((int64_t)1 << 40) /* integrator clamp, 2^-16 comparator LSB */
#define NOISE_TABLE 4096

typedef struct {
    int n;
    int32_t h;
    int32_t b0, b1, a1, ki;
    uint32_t gate;
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
static inline int64_t asr(int64_t x, int s) { return x >= 0 ? x >> s : ~((~x) >> s); }

static inline int64_t clamp64(int64_t x, int64_t lim, uint32_t *sat) {
    if (x > lim) { (*sat)++; return lim; }
    if (x < -lim) { (*sat)++; return -lim; }
    return x;
}

/* The twin's tick (ptsa-core/c-twin/ptsa_twin.c); returns 1 for positive polarity. */
static inline int tick(const config_t *c, state_t *s, int16_t x, int *cycle, int64_t *gate_p) {
    int32_t h = c->h;
    int64_t e = x;
    int64_t acc = (int64_t)c->b0 * e + (int64_t)c->b1 * s->e_prev + (int64_t)c->a1 * s->lead;
    int64_t lead = asr(acc + ((int64_t)1 << 15), 16);
    s->lead = (int32_t)lead;
    s->e_prev = (int32_t)e;
    s->integ = clamp64(s->integ + (int64_t)c->ki * e, INTEG_LIMIT, &s->sat_integ);
    int32_t u = (int32_t)clamp64(lead + asr(s->integ, 16), R, &s->sat_out);
    uint32_t k = s->ticks & (uint32_t)(c->n - 1);
    int32_t v = u + s->carry;
    int32_t r = h * (c->n - 1 - 2 * (int32_t)k);
    if (!s->switched && v + r < 0) {
        s->switched = true;
        s->latched = v;
        s->n = (uint16_t)k;
    }
    int positive = !s->switched;
    s->pulses += (uint32_t)positive;
    s->ticks += 1;
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
    *gate_p = -1;
    if (s->ticks - s->t0 == c->gate) {
        *gate_p = s->pulses - s->p0;
        s->t0 = s->ticks;
        s->p0 = s->pulses;
    }
    return positive;
}

typedef struct {
    config_t c;
    double gain, bias, noise, theta_stop;
    int u0;
    uint64_t rng;
    double phi[2][4][4]; /* free, on a stop */
    double add[3][2][4]; /* region (free, upper, lower) x polarity (+, -) */
    double x0[4];
    double table[NOISE_TABLE];
} params_t;

static double rd(void) {
    double v;
    if (scanf("%lf", &v) != 1) { fprintf(stderr, "static_loop: bad parameters\n"); exit(2); }
    return v;
}

static long long rdi(void) {
    long long v;
    if (scanf("%lld", &v) != 1) { fprintf(stderr, "static_loop: bad parameters\n"); exit(2); }
    return v;
}

static inline void step(const double p[4][4], const double x[4], const double a[4], double o[4]) {
    o[0] = a[0] + (p[0][0] * x[0] + p[0][1] * x[1]) + p[0][2] * x[2];
    o[1] = a[1] + (p[1][0] * x[0] + p[1][1] * x[1]) + p[1][2] * x[2];
    o[2] = a[2] + p[2][2] * x[2];
    o[3] = a[3] + (p[3][0] * x[0] + p[3][1] * x[1]) + (p[3][2] * x[2] + p[3][3] * x[3]);
}

static inline double normal(uint64_t *st, const double *table) {
    *st += 0xa0761d6478bd642fULL;
    unsigned __int128 t = (unsigned __int128)*st * (*st ^ 0xe7037ed1a0b428dbULL);
    uint64_t r = (uint64_t)(t >> 64) ^ (uint64_t)t;
    return table[(r >> 52) & (NOISE_TABLE - 1)];
}

/* settle + ticks from the initial state; returns the pulses over the last `ticks`. */
static uint32_t run(const params_t *P, uint64_t settle, uint64_t ticks, double x_out[4]) {
    state_t s = {0};
    double x[4] = {P->x0[0], P->x0[1], P->x0[2], P->x0[3]};
    int neg = P->u0 < 0;
    uint64_t rng = P->rng;
    uint32_t p0 = 0;
    uint64_t total = settle + ticks;
    for (uint64_t k = 0; k < total; k++) {
        if (k == settle) p0 = s.pulses;
        double bias = P->bias;
        if (P->noise != 0.0) bias += P->noise * normal(&rng, P->table);
        double z = x[3] * P->gain + bias;
        z = z > 0.0 ? z : 0.0;
        z = z < 65535.0 ? z : 65535.0;
        int16_t code = (int16_t)(uint16_t)((uint32_t)z ^ 0x8000u);
        int cycle;
        int64_t gate_p;
        int pos = tick(&P->c, &s, code, &cycle, &gate_p);
        double o[4];
        if (fabs(x[0]) <= P->theta_stop) {
            step(P->phi[0], x, P->add[0][neg], o);
        } else {
            int r = x[0] > 0.0 ? 1 : 2;
            step(P->phi[1], x, P->add[r][neg], o);
        }
        x[0] = o[0]; x[1] = o[1]; x[2] = o[2]; x[3] = o[3];
        neg = !pos;
    }
    for (int i = 0; i < 4; i++) x_out[i] = x[i];
    return s.pulses - p0;
}

int main(int argc, char **argv) {
    if (argc != 4) { fprintf(stderr, "usage: static_loop SETTLE TICKS RUNS < params\n"); return 2; }
    uint64_t settle = strtoull(argv[1], NULL, 10);
    uint64_t ticks = strtoull(argv[2], NULL, 10);
    int runs = atoi(argv[3]);
    static params_t P;
    P.c.b0 = (int32_t)rdi(); P.c.b1 = (int32_t)rdi(); P.c.a1 = (int32_t)rdi();
    P.c.ki = (int32_t)rdi(); P.c.n = (int)rdi(); P.c.gate = (uint32_t)rdi();
    P.c.shaping = rdi() != 0;
    P.c.h = R / P.c.n;
    P.gain = rd(); P.bias = rd(); P.noise = rd(); P.theta_stop = rd();
    P.u0 = (int)rdi();
    { unsigned long long v; if (scanf("%llu", &v) != 1) return 2; P.rng = v; }
    for (int r = 0; r < 2; r++)
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++) P.phi[r][i][j] = rd();
    for (int r = 0; r < 3; r++)
        for (int u = 0; u < 2; u++)
            for (int j = 0; j < 4; j++) P.add[r][u][j] = rd();
    for (int j = 0; j < 4; j++) P.x0[j] = rd();
    for (int j = 0; j < NOISE_TABLE; j++) P.table[j] = rd();
    for (int i = 0; i < runs; i++) {
        struct timespec t0, t1;
        double x[4];
        clock_gettime(CLOCK_MONOTONIC, &t0);
        uint32_t pulses = run(&P, settle, ticks, x);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double e = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        uint64_t b[4];
        memcpy(b, x, sizeof b);
        printf("rate=%.6e pulses=%" PRIu32 " x=%016" PRIx64 ",%016" PRIx64 ",%016" PRIx64
               ",%016" PRIx64 "\n",
               (double)(settle + ticks) / e, pulses, b[0], b[1], b[2], b[3]);
        fflush(stdout);
    }
    return 0;
}
