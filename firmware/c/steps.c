/*
 * The controller's hot paths written in plain C, for a like-for-like comparison of cycles with
 * the Rust of flexarm-core (`cargo fw-bench`, docs/performance.md).
 *
 * The same work as the Rust, step for step: the same formulas in the same order where the
 * order decides the rounding, the same checks, the same float-only sin/cos and exp (the
 * polynomials of core/src/fastmath.rs), so that the bench can check that both give the same
 * torques and voltages. Written the way a C programmer would write it for this core: the
 * controller's constants computed once in `init` (Model::new does the same in Rust), one
 * struct in the order the steps read it, no libm.
 *
 * - `eq7`: Eq. 7's joint rows, (q, q', theta_d, theta_d', theta_d'') -> (tau1, tau2), with
 *   B(q) and the closed forms of C(q, q') v (core/src/model.rs, module docs);
 * - `piezo_step`: the film gate (range and latch in one test), the filtered derivative with
 *   the gain folded in, saturation to the window [v_min, v_max], the NaN of a first sample;
 * - `motor_step`: the complete motor step of Controller::motor_step in steady state: latch,
 *   clock and sample checks (range, encoder jump), observer correction, B(q) terms and S^-1,
 *   the trapezoid's sample, Eq. 16 (Eq. 7 + the robust term through the joints), saturation,
 *   the observer's prediction.
 *
 * Built twice by firmware/build.rs (feature `c-compare`), at -O2 and -O3, with
 * -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard -ffp-contract=off (the Rust never fuses a
 * multiply and an add either); SUFFIX names each build's symbols. SI units, the frames and
 * coordinates of core/src/lib.rs.
 */
#include <stdint.h>

#ifndef SUFFIX
#error "build with -DSUFFIX=_o2 (or _o3): the suffix of this build's symbols"
#endif
#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define NAME(x) CAT(x, SUFFIX)

/* The parameters the bench hands over, the same values the Rust controller is built from
 * (firmware/src/bin/bench.rs: `CParams`, field for field). */
struct fc_params {
    /* The arm (ArmParams): lengths [m], masses [kg], inertias [kg m^2], modal data. */
    float a1, a2, m1, m2, m_h2, i_1, i_h1, i_h2, i_2_extra;
    float omega[2], zeta[2], mass_integral[2], moment_integral[2];
    /* Gains of Eqs. 7 and 11. */
    float lambda[4], kp[4], d_delta[2], epsilon[2], phi[2], epsilon_floor, mu;
    /* Torque limits [N m], the piezo window [V]. */
    float tau_max[2], v_a_min, v_a_max;
    /* The piezo law V_a = -k_c V_f' [s], the derivative filter's corner [Hz], its period [s]. */
    float k_c, cutoff_hz, piezo_period;
    /* The patch's modal force per volt C_a. */
    float c_a[2];
    /* The observer: L^T (each state's three gains side by side), film map, period [s]. */
    float gain_t[8][3];
    float c_f[2], period;
    /* The sensors' ranges. */
    float theta_min[2], theta_max[2], speed_max, v_f_max;
    /* The trapezoid: start and amplitude [rad], duration and ramp time [s]. */
    float start[2], amplitude[2], duration, ramp;
    /* Motor periods without a sample before a stale fault; 1 for Eq. 16, 0 for Eq. 7. */
    uint32_t stale_limit, robust;
    /* The joints' integral action: K_i [1/s] and the bound on |K_i z| [rad]. */
    float ki[2], integral_limit[2];
};

/* One state of the bench (firmware/src/bin/bench/like.rs: `CState`, repr(C)). */
struct fc_state {
    float t;
    float q[4], qd[4];
    float theta_d[2], theta_d_dot[2], theta_d_ddot[2];
    float y_theta[2], y_v_f;
};

/* Fault codes, as core/src/fault.rs numbers them (0: none). */
enum { NON_FINITE = 1, OUT_OF_RANGE = 2, ENCODER_JUMP = 4, SINGULAR = 9 };
enum { HOLD = 0, TRAPEZOID = 1 };

/* The controller: the piezo loop's state first, in the order its step reads it. */
struct fc_ctrl {
    float film_gate, fa, fb, x_prev, y, v_max, v_min, v_a;
    uint8_t fault, armed, has_previous, trajectory;
    uint32_t missed, stale_limit, robust;
    /* B(q): A, J(0), a1 m2 a2 / 2, a1 v, w, J(0) - |w|^2, K, D. */
    float a_const, j_const, a1_s2, a1_v[2], w[2], w_sq, k[2], d[2];
    float lambda[4], kp[2], d_delta[2], epsilon[2], phi[2], epsilon_floor, mu2;
    float tau_max[2], c_a[2];
    /* The estimate, the gain, the film map, the period. */
    float q[4], qd[4], gain_t[8][3], c_f[2], period;
    float theta_min[2], theta_max[2], jump, v_f_max, previous[2];
    /* The trapezoid: start, amplitude, duration, ramp, 1/(T - t_a), its acceleration, the
     * start of the deceleration, s at the end of the first ramp. */
    float start[2], amplitude[2], duration, ramp, rate, accel, cruise_end, s_ramp;
    /* The integral action: K_i, the bound on |K_i z|, z [rad s]. */
    float ki[2], integral_limit[2], z[2];
};

/* The bench keeps the controller in an opaque, aligned block of this size. */
_Static_assert(sizeof(struct fc_ctrl) <= 512, "fc_ctrl outgrew the bench's block");

static inline int finite(float x) { return __builtin_isfinite(x); }

static inline float fabs_(float x) { return __builtin_fabsf(x); }

static inline uint32_t bits(float x) {
    union { float f; uint32_t u; } v = {.f = x};
    return v.u;
}

static inline float from_bits(uint32_t u) {
    union { uint32_t u; float f; } v = {.u = u};
    return v.f;
}

/* 1.5 * 2^23: y + S - S rounds |y| < 2^22 to the nearest integer, whose low bits y + S holds. */
#define ROUND_SHIFT 12582912.0f

/* sin and cos for |x| <= 2^13: a three-part Cody-Waite reduction by pi/2 and minimax
 * polynomials of degree 7 and 8 on |r| <= pi/4 (the coefficients of core/src/fastmath.rs). */
static void sin_cos(float x, float *s_out, float *c_out) {
    /* |x| <= 2^13 as one integer comparison (fastmath.rs: in_fast_range; NaN and inf fail it).
     * The textbook (y + S) - S below, not the Rust's S - (y + S): GCC reuses the register
     * that holds S either way, and its Eq. 7 is a cycle slower with the negated form. */
    if (!(bits(x) << 1 <= 0x8C000000u)) {
        /* Far outside any joint range (never in the bench): folded by whole turns. */
        if (!finite(x)) {
            *s_out = *c_out = __builtin_nanf("");
            return;
        }
        while (fabs_(x) > 8192.0f)
            x -= (float)(int32_t)(x / 6.2831855f) * 6.2831855f;
    }
    float shifted = x * 0.63661975f + ROUND_SHIFT;
    float k = shifted - ROUND_SHIFT;
    float r = ((x - k * 1.5703125f) - k * 4.837513e-4f) - k * 7.54979e-8f;
    float r2 = r * r;
    float s = r + r * r2 * (-0.16666655f + r2 * (0.008332178f + r2 * -0.000195173f));
    float c = 1.0f + r2 * (-0.5f + r2 * (0.041666646f + r2 * (-0.0013887368f + r2 * 2.4438452e-5f)));
    switch (bits(shifted) & 3) {
    case 0: *s_out = s; *c_out = c; break;
    case 1: *s_out = c; *c_out = -s; break;
    case 2: *s_out = -s; *c_out = -c; break;
    default: *s_out = -c; *c_out = s; break;
    }
}

/* e^x: x = k ln 2 + r, a degree-5 minimax polynomial on |r| <= ln 2 / 2, 2^k from the bits. */
static inline float exp_(float x) {
    if (!(x >= -87.0f && x <= 88.0f))
        return x != x ? x : x > 0.0f ? __builtin_inff() : 0.0f;
    float shifted = x * 1.442695f + ROUND_SHIFT;
    float k = shifted - ROUND_SHIFT;
    float r = (x - k * 0.69314575f) - k * 1.4286068e-6f;
    float p = 1.0f + r * (0.9999997f + r * (0.4999915f + r * (0.16667636f + r * (0.04189793f + r * 0.008290315f))));
    return from_bits((bits(shifted) - bits(ROUND_SHIFT) + 127u) << 23) * p;
}

void NAME(flexarm_c_init)(struct fc_ctrl *c, const struct fc_params *p) {
    *c = (struct fc_ctrl){0};
    c->film_gate = p->v_f_max;
    /* The Tustin filtered derivative y = a y + b (x - x_prev), the gain -k_c folded into b. */
    float wc = 6.2831855f * p->cutoff_hz, den = 2.0f + wc * p->piezo_period;
    c->fa = (2.0f - wc * p->piezo_period) / den;
    c->fb = -p->k_c * 2.0f * wc / den;
    c->x_prev = __builtin_nanf("");
    c->v_max = p->v_a_max;
    c->v_min = p->v_a_min;
    c->armed = 1;
    c->trajectory = TRAPEZOID;
    c->stale_limit = p->stale_limit;
    c->robust = p->robust;
    float a1 = p->a1;
    c->a_const = p->i_h1 + p->i_1 + p->m1 * a1 * a1 * 0.25f + (p->m_h2 + p->m2) * a1 * a1;
    c->j_const = p->i_h2 + p->i_2_extra + p->m2 * p->a2 * p->a2 / 3.0f;
    c->a1_s2 = a1 * p->m2 * p->a2 * 0.5f;
    for (int i = 0; i < 2; i++) {
        c->a1_v[i] = p->mass_integral[i] * a1;
        c->w[i] = p->moment_integral[i];
        c->k[i] = p->omega[i] * p->omega[i];
        c->d[i] = p->zeta[i] * 2.0f * p->omega[i];
        c->kp[i] = p->kp[i];
        c->d_delta[i] = p->d_delta[i];
        c->epsilon[i] = p->epsilon[i];
        c->phi[i] = p->phi[i];
        c->tau_max[i] = p->tau_max[i];
        c->c_a[i] = p->c_a[i];
        c->c_f[i] = p->c_f[i];
        c->theta_min[i] = p->theta_min[i];
        c->theta_max[i] = p->theta_max[i];
        c->start[i] = p->start[i];
        c->amplitude[i] = p->amplitude[i];
        c->ki[i] = p->ki[i];
        c->integral_limit[i] = p->integral_limit[i];
    }
    c->w_sq = c->w[0] * c->w[0] + c->w[1] * c->w[1];
    for (int i = 0; i < 4; i++)
        c->lambda[i] = p->lambda[i];
    c->epsilon_floor = p->epsilon_floor;
    c->mu2 = p->mu * p->mu;
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 3; j++)
            c->gain_t[i][j] = p->gain_t[i][j];
    c->period = p->period;
    c->jump = p->speed_max * p->period;
    c->v_f_max = p->v_f_max;
    c->duration = p->duration;
    c->ramp = p->ramp;
    c->rate = 1.0f / (p->duration - p->ramp);
    c->accel = c->rate / p->ramp;
    c->cruise_end = p->duration - p->ramp;
    c->s_ramp = 0.5f * c->accel * p->ramp * p->ramp;
}

/* At rest at the encoder angles theta, undeformed, no previous sample (Controller::reset_observer). */
void NAME(flexarm_c_reset)(struct fc_ctrl *c, const float theta[2]) {
    c->has_previous = 0;
    c->q[0] = theta[0];
    c->q[1] = theta[1];
    c->q[2] = c->q[3] = 0.0f;
    for (int i = 0; i < 4; i++)
        c->qd[i] = 0.0f;
}

static void trip(struct fc_ctrl *c, uint8_t fault) {
    c->v_a = 0.0f;
    c->film_gate = -1.0f;
    if (c->fault == 0)
        c->fault = fault;
}

/* The terms of B(q) and dB/dq at one configuration, and S^-1 (core/src/model.rs: `Terms`). */
struct terms {
    float b11, b12, b22, b13, b14, dh, d13, d14;
    float si11, si12, si22;
};

static inline void terms(const struct fc_ctrl *c, const float q[4], struct terms *t) {
    float s2, c2;
    sin_cos(q[1], &s2, &c2);
    float d1 = q[2], d2 = q[3];
    float jd = c->j_const + d1 * d1 + d2 * d2;
    float a1vd = c->a1_v[0] * d1 + c->a1_v[1] * d2;
    float h = c->a1_s2 * c2 - s2 * a1vd;
    t->b11 = c->a_const + jd + h + h;
    t->b12 = jd + h;
    t->b22 = jd;
    t->b13 = c->a1_v[0] * c2 + c->w[0];
    t->b14 = c->a1_v[1] * c2 + c->w[1];
    t->dh = -c->a1_s2 * s2 - c2 * a1vd;
    t->d13 = -c->a1_v[0] * s2;
    t->d14 = -c->a1_v[1] * s2;
}

/* S^-1 of the Schur complement S = B_tt - B_td B_td^T; 0 unless S is positive definite. */
static inline int schur_inverse(const struct fc_ctrl *c, struct terms *t) {
    float s11 = t->b11 - t->b13 * t->b13 - t->b14 * t->b14;
    float s12 = t->b12 - t->b13 * c->w[0] - t->b14 * c->w[1];
    float s22 = t->b22 - c->w_sq;
    float det = s11 * s22 - s12 * s12;
    float inv = 1.0f / det;
    t->si22 = s11 * inv;
    if (!(det > 0.0f && t->si22 > 0.0f))
        return 0;
    t->si11 = s22 * inv;
    t->si12 = -s12 * inv;
    return 1;
}

/* Eq. 7's joint rows on the terms: B q''_r + C(q, q') q'_r - K_p s, with the reference signals
 * of the target (th_d, th_d', th_d''); s_out gets the modal rows of s. */
static inline void eq7_joints(const struct fc_ctrl *c, const struct terms *t, const float q[4],
                              const float qd[4], const float th_d[2], const float th_d1[2],
                              const float th_d2[2], float tau[2], float s_out[2]) {
    const float *l = c->lambda;
    /* q'_r = th_d' - Lambda (q - q_d) = (v0..v3), q''_r = th_d'' - Lambda (q' - q_d') = (a0..a3). */
    float qt0 = q[0] - th_d[0], qt1 = q[1] - th_d[1];
    float v0 = th_d1[0] - l[0] * qt0, v1 = th_d1[1] - l[1] * qt1;
    float v2 = -(l[2] * q[2]), v3 = -(l[3] * q[3]);
    float a0 = th_d2[0] - l[0] * (qd[0] - th_d1[0]), a1 = th_d2[1] - l[1] * (qd[1] - th_d1[1]);
    float a2 = -(l[2] * qd[2]), a3 = -(l[3] * qd[3]);
    float d1 = q[2], d2 = q[3];
    /* (sigma, j, a) of q' and of v = q'_r. */
    float sg = qd[0] + qd[1], j = d1 * qd[2] + d2 * qd[3], aa = j + (t->d13 * qd[2] + t->d14 * qd[3]);
    float sv = v0 + v1, jv = d1 * v2 + d2 * v3, av = jv + (t->d13 * v2 + t->d14 * v3);
    float b0 = t->b11 * a0 + t->b12 * a1 + t->b13 * a2 + t->b14 * a3;
    float b1 = t->b12 * a0 + t->b22 * a1 + c->w[0] * a2 + c->w[1] * a3;
    float c0 = aa * sv + av * sg + t->dh * (qd[1] * sv + qd[0] * v1);
    float c1 = j * sv + jv * sg - t->dh * qd[0] * v0;
    tau[0] = b0 + c0 - c->kp[0] * (qd[0] - v0);
    tau[1] = b1 + c1 - c->kp[1] * (qd[1] - v1);
    s_out[0] = qd[2] - v2;
    s_out[1] = qd[3] - v3;
}

void NAME(flexarm_c_eq7)(const struct fc_ctrl *c, const struct fc_state *s, float tau[2]) {
    struct terms t;
    float s_delta[2];
    terms(c, s->q, &t);
    eq7_joints(c, &t, s->q, s->qd, s->theta_d, s->theta_d_dot, s->theta_d_ddot, tau, s_delta);
}

void NAME(flexarm_c_piezo_step)(struct fc_ctrl *c, const float *v_f, float *v_a) {
    float x = *v_f;
    /* One test: a closed gate (latched or disarmed), NaN, +-inf and out-of-range samples. */
    if (!(fabs_(x) < c->film_gate)) {
        if (c->armed && c->fault == 0)
            trip(c, finite(x) ? OUT_OF_RANGE : NON_FINITE);
        *v_a = 0.0f;
        return;
    }
    float y = c->fa * c->y + c->fb * (x - c->x_prev);
    c->y = y;
    c->x_prev = x;
    float out;
    if (!(y <= c->v_max)) {
        if (y > c->v_max) {
            out = c->v_max;
        } else {
            /* NaN: the first sample after a reset; the filter restarts at 0. */
            c->y = 0.0f;
            out = 0.0f;
        }
    } else {
        out = y < c->v_min ? c->v_min : y;
    }
    c->v_a = out;
    *v_a = out;
}

static inline float saturate(float x, float limit) {
    if (fabs_(x) <= limit)
        return x;
    return x > 0.0f ? limit : x < 0.0f ? -limit : 0.0f;
}

/* The floored boundary layer max(eps e^{-phi t}, floor). */
static inline float layer(float eps, float decay, float floor) {
    float l = eps * decay;
    return l > floor ? l : floor;
}

/* The safe command: zero torque, amplifiers disabled. */
static int safe(float tau_out[2]) {
    tau_out[0] = tau_out[1] = 0.0f;
    return 0;
}

/* The motor law on the target (th_d, th_d', th_d'') at `time`: Eq. 7, then Eq. 16's robust
 * term through the joints, and the saturation. 0 after tripping SINGULAR on torques that are not
 * finite. Inlined into each branch of the integral's test, as the Rust runs it
 * (`Controller::law`). */
static inline __attribute__((always_inline)) int motor_law(struct fc_ctrl *c, const struct terms *t,
                                                          const float q[4], const float qd[4],
                                                          const float th_d[2], const float th_d1[2],
                                                          const float th_d2[2], float time,
                                                          float tau[2]) {
    float s_delta[2];
    eq7_joints(c, t, q, qd, th_d, th_d1, th_d2, tau, s_delta);
    if (c->robust) {
        float e1 = exp_(-c->phi[0] * time);
        float e2 = c->phi[1] == c->phi[0] ? e1 : exp_(-c->phi[1] * time);
        float dd1 = qd[2], dd2 = qd[3];
        float p1 = fabs_(dd1 * s_delta[0]), p2 = fabs_(dd2 * s_delta[1]);
        float n1 = p1 + layer(c->epsilon[0], e1, c->epsilon_floor);
        float n2 = p2 + layer(c->epsilon[1], e2, c->epsilon_floor);
        float rn = 1.0f / (n1 * n2);
        float f1 = p1 * n2 * rn, f2 = p2 * n1 * rn;
        float acc1 = -c->d_delta[0] * (1.0f + f1) * dd1;
        float acc2 = -c->d_delta[1] * (1.0f + f2) * dd2;
        /* M = -B_dt S^-1, then the damped least squares M^T (M M^T + mu^2 sigma^2 I)^-1 a. */
        float m11 = -(t->b13 * t->si11 + c->w[0] * t->si12), m12 = -(t->b13 * t->si12 + c->w[0] * t->si22);
        float m21 = -(t->b14 * t->si11 + c->w[1] * t->si12), m22 = -(t->b14 * t->si12 + c->w[1] * t->si22);
        float g11 = m11 * m11 + m12 * m12, g12 = m11 * m21 + m12 * m22, g22 = m21 * m21 + m22 * m22;
        float reg = c->mu2 * (g11 + g22) * 0.5f;
        g11 += reg;
        g22 += reg;
        float det = g11 * g22 - g12 * g12;
        if (!(det <= 0.0f)) {
            float inv = 1.0f / det;
            float y1 = (g22 * acc1 - g12 * acc2) * inv, y2 = (g11 * acc2 - g12 * acc1) * inv;
            tau[0] += m11 * y1 + m21 * y2;
            tau[1] += m12 * y1 + m22 * y2;
        }
    }
    if (!finite(tau[0] + tau[1])) {
        trip(c, SINGULAR);
        return 0;
    }
    tau[0] = saturate(tau[0], c->tau_max[0]);
    tau[1] = saturate(tau[1], c->tau_max[1]);
    return 1;
}

/* The complete motor step at s->t with the sample (s->y_theta, s->y_v_f). Writes the
 * amplifiers' torques (0 in the safe state); returns their enable. */
int NAME(flexarm_c_motor_step)(struct fc_ctrl *c, const struct fc_state *s, float tau_out[2]) {
    if (c->fault)
        return safe(tau_out);
    float time = s->t;
    if (!finite(time)) {
        trip(c, NON_FINITE);
        return safe(tau_out);
    }
    /* A fresh sample: the staleness count restarts. */
    c->missed = 0;
    float th0 = s->y_theta[0], th1 = s->y_theta[1], v_f = s->y_v_f;
    if (!(th0 >= c->theta_min[0] && th0 <= c->theta_max[0] && th1 >= c->theta_min[1] &&
          th1 <= c->theta_max[1] && fabs_(v_f) < c->v_f_max)) {
        trip(c, finite(th0) && finite(th1) && finite(v_f) ? OUT_OF_RANGE : NON_FINITE);
        return safe(tau_out);
    }
    if (c->has_previous &&
        (fabs_(th0 - c->previous[0]) > c->jump || fabs_(th1 - c->previous[1]) > c->jump)) {
        trip(c, ENCODER_JUMP);
        return safe(tau_out);
    }
    /* The observer's correction x += L (y - C x). */
    float r0 = th0 - c->q[0], r1 = th1 - c->q[1];
    float r2 = v_f - (c->c_f[0] * c->q[2] + c->c_f[1] * c->q[3]);
    for (int i = 0; i < 4; i++) {
        const float *g = c->gain_t[i], *h = c->gain_t[i + 4];
        c->q[i] += g[0] * r0 + g[1] * r1 + g[2] * r2;
        c->qd[i] += h[0] * r0 + h[1] * r1 + h[2] * r2;
    }
    c->previous[0] = th0;
    c->previous[1] = th1;
    c->has_previous = 1;

    float q[4], qd[4];
    for (int i = 0; i < 4; i++) {
        q[i] = c->q[i];
        qd[i] = c->qd[i];
    }
    struct terms t;
    terms(c, q, &t);
    if (!schur_inverse(c, &t)) {
        /* What the prediction would trip after the law (the Rust trips it here too). */
        trip(c, SINGULAR);
        return safe(tau_out);
    }

    /* The trajectory's sample. */
    float th_d[2], th_d1[2], th_d2[2];
    if (c->trajectory == TRAPEZOID) {
        float p, pd, pdd;
        if (!(time >= 0.0f)) {
            p = pd = pdd = 0.0f;
        } else if (time < c->ramp) {
            p = 0.5f * c->accel * time * time;
            pd = c->accel * time;
            pdd = c->accel;
        } else if (time < c->cruise_end) {
            p = c->s_ramp + c->rate * (time - c->ramp);
            pd = c->rate;
            pdd = 0.0f;
        } else if (time < c->duration) {
            float r = c->duration - time;
            p = 1.0f - 0.5f * c->accel * r * r;
            pd = c->accel * r;
            pdd = -c->accel;
        } else {
            p = 1.0f;
            pd = pdd = 0.0f;
        }
        for (int i = 0; i < 2; i++) {
            th_d[i] = c->start[i] + c->amplitude[i] * p;
            th_d1[i] = c->amplitude[i] * pd;
            th_d2[i] = c->amplitude[i] * pdd;
        }
    } else {
        for (int i = 0; i < 2; i++) {
            th_d[i] = c->start[i];
            th_d1[i] = th_d2[i] = 0.0f;
        }
    }

    /* The joints' integral action (core/src/control/integral.rs), when the gains have it: the
     * law tracks th_d - K_i z, th_d' - K_i (q - th_d), th_d'' - K_i (q' - th_d'), and the
     * period integrates the encoders' error, not while a joint's torque is at its limit pushing
     * the way its error asks, |K_i z| within its bound. One test, the law in each branch. */
    float tau[2];
    if (c->ki[0] != 0.0f || c->ki[1] != 0.0f) {
        float pending[2] = {th0 - th_d[0], th1 - th_d[1]};
        for (int i = 0; i < 2; i++) {
            float k = c->ki[i];
            float d1 = th_d1[i] - k * (q[i] - th_d[i]);
            float d2 = th_d2[i] - k * (qd[i] - th_d1[i]);
            th_d[i] -= k * c->z[i];
            th_d1[i] = d1;
            th_d2[i] = d2;
        }
        if (!motor_law(c, &t, q, qd, th_d, th_d1, th_d2, time, tau))
            return safe(tau_out);
        for (int i = 0; i < 2; i++) {
            float k = c->ki[i], e = pending[i];
            int winding = fabs_(tau[i]) >= c->tau_max[i] && e * tau[i] < 0.0f;
            if (k <= 0.0f || winding)
                continue;
            float next = c->z[i] + e * c->period, bound = c->integral_limit[i] / k;
            next = next < -bound ? -bound : next;
            c->z[i] = next > bound ? bound : next;
        }
    } else if (!motor_law(c, &t, q, qd, th_d, th_d1, th_d2, time, tau)) {
        return safe(tau_out);
    }

    /* The prediction: q'' = B^-1 (u - C q' - K q - D q') with u = (tau, C_a V_a), one
     * semi-implicit Euler step. */
    float sg = qd[0] + qd[1], j = q[2] * qd[2] + q[3] * qd[3];
    float aa = j + (t.d13 * qd[2] + t.d14 * qd[3]);
    float two_s = sg + sg, w0_sq = qd[0] * qd[0], s_sq = sg * sg;
    float u0 = tau[0] - (two_s * aa + t.dh * qd[1] * (sg + qd[0]));
    float u1 = tau[1] - (two_s * j - t.dh * w0_sq);
    float u2 = c->c_a[0] * c->v_a + (t.d13 * w0_sq + q[2] * s_sq) - c->k[0] * q[2] - c->d[0] * qd[2];
    float u3 = c->c_a[1] * c->v_a + (t.d14 * w0_sq + q[3] * s_sq) - c->k[1] * q[3] - c->d[1] * qd[3];
    float rt0 = u0 - t.b13 * u2 - t.b14 * u3, rt1 = u1 - c->w[0] * u2 - c->w[1] * u3;
    float x0 = t.si11 * rt0 + t.si12 * rt1, x1 = t.si12 * rt0 + t.si22 * rt1;
    float qdd[4] = {x0, x1, u2 - t.b13 * x0 - c->w[0] * x1, u3 - t.b14 * x0 - c->w[1] * x1};
    float h = c->period, sum = 0.0f;
    for (int i = 0; i < 4; i++) {
        qd[i] += qdd[i] * h;
        q[i] += qd[i] * h;
        sum += q[i] + qd[i];
    }
    if (!finite(sum)) {
        trip(c, SINGULAR);
        return safe(tau_out);
    }
    for (int i = 0; i < 4; i++) {
        c->q[i] = q[i];
        c->qd[i] = qd[i];
    }
    tau_out[0] = tau[0];
    tau_out[1] = tau[1];
    return 1;
}
