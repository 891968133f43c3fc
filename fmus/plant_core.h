/*
 * The plant of the hybridsim plant FMU, shared by its FMI 2.0 (plant.c) and
 * FMI 3.0 (plant3.c) interfaces: the arm of Raibert & Craig (1981) with
 * stick-slip friction (eqs 5, 6, 11), the hand on the wrist force sensor
 * (eqs 7, 8) and the unilateral reaction surface (eq 9), as in docs/model.md.
 * The same equations as blocks/paper/manipulator.py, blocks/paper/wrist.py and
 * blocks/paper/surface.py.
 *
 * Every variable lives in r[], indexed by its value reference (plant_vars.h,
 * generated with modelDescription.xml from fmus/plant_model.py). The file that
 * includes this one defines PlantCallbacks (its FMI version's logger) first.
 */
#ifndef PLANT_CORE_H
#define PLANT_CORE_H
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "plant_vars.h"

typedef enum { MODE_INSTANTIATED, MODE_INIT, MODE_EVENT, MODE_CONTINUOUS, MODE_STEP, MODE_TERMINATED } Mode;

typedef struct {
    double r[N_VARS];
    double time;
    Mode mode;
    int is_cs;
    char name[128];
    PlantCallbacks cb;
} Plant;

#define R(v) (p->r[v])

/* ---- the model ---------------------------------------------------------- */

/* eq 11, Karnopp: slide above the band, else cancel F and bring v to rest, up to tau_s.
 * With `stribeck` the sliding level falls from tau_s to tau_c: tc + (ts - tc) exp(-(v/vs)^2). */
static double friction(const Plant *p, double v, double F, double m, int joint) {
    double tc = joint == 1 ? R(VR_TAU_C_1) : R(VR_TAU_C_2);
    double ts = joint == 1 ? R(VR_TAU_S_1) : R(VR_TAU_S_2);
    double vs = joint == 1 ? R(VR_STRIBECK_VELOCITY_1) : R(VR_STRIBECK_VELOCITY_2);
    double b, level;
    if (R(VR_FRICTION) == 0.0) return 0.0;
    if (fabs(v) >= R(VR_STICK_BAND)) {
        level = R(VR_STRIBECK) != 0.0 ? tc + (ts - tc) * exp(-(v / vs) * (v / vs)) : tc;
        return v > 0 ? -level : level;
    }
    b = -F - m * v / R(VR_STICK_TIME);
    return b > ts ? ts : (b < -ts ? -ts : b);
}

/* hand position and velocity in {C}; penetration and contact force (eq 9) */
static void contact(const Plant *p, const double *x, double *hand, double *vel, double *pen, double *fx) {
    double q1 = x[0], q2 = x[1], qd1 = x[2], qd2 = x[3], w1 = x[4], w2 = x[5], wd1 = x[6], wd2 = x[7];
    double c = cos(q1), s = sin(q1), l = R(VR_L);
    double rw1 = w1 * c - w2 * s, rw2 = w1 * s + w2 * c, pd, f;
    hand[0] = q2 * c + l * s + rw1;
    hand[1] = q2 * s - l * c + rw2;
    vel[0] = (-q2 * s + l * c) * qd1 + c * qd2 + wd1 * c - wd2 * s - qd1 * rw2;
    vel[1] = (q2 * c + l * s) * qd1 + s * qd2 + wd1 * s + wd2 * c + qd1 * rw1;
    *pen = hand[0] - R(VR_X_SURFACE);
    pd = vel[0] - R(VR_V_SURFACE);
    if (R(VR_UNILATERAL) != 0.0) {
        f = *pen > 0.0 ? R(VR_KR) * *pen + R(VR_BR) * pd : 0.0;
        *fx = f > 0.0 ? f : 0.0;
    } else {
        *fx = R(VR_KR) * *pen + R(VR_BR) * pd;
    }
}

static void derivatives(const Plant *p, const double *x, double *dx) {
    double q1 = x[0], q2 = x[1], v1 = x[2], v2 = x[3], w1 = x[4], w2 = x[5], wd1 = x[6], wd2 = x[7];
    double hand[2], vel[2], pen, fx;
    double kw = R(VR_KW), bw = R(VR_BW), m3 = R(VR_M3), l = R(VR_L);
    double f1 = kw * w1 + bw * wd1, f2 = kw * w2 + bw * wd2; /* wrist force on the arm, {H} */
    double i1 = R(VR_I1_0) + R(VR_I1_1) * q2 + R(VR_I1_2) * q2 * q2;
    double m2 = R(VR_M2) + m3;
    double F1 = R(VR_TAU_1) + q2 * f2 + l * f1 - R(VR_B_1) * v1; /* eq 5 without B1 */
    double F2 = R(VR_TAU_2) + f1 - R(VR_B_2) * v2;               /* eq 6 without B2 */
    contact(p, x, hand, vel, &pen, &fx);
    dx[0] = v1;
    dx[1] = v2;
    dx[2] = (F1 + friction(p, v1, F1, i1, 1)) / i1;
    dx[3] = (F2 + friction(p, v2, F2, m2, 2)) / m2;
    dx[4] = wd1;
    dx[5] = wd2;
    dx[6] = (-kw * w1 - bw * wd1 - fx * cos(q1)) / m3; /* eq 7 */
    dx[7] = (-kw * w2 - bw * wd2 + fx * sin(q1)) / m3; /* eq 8 */
}

/* the event indicators: slide <-> stick on each joint, contact make / break */
static void event_indicators(const Plant *p, const double *x, double *z) {
    double hand[2], vel[2], pen, fx;
    contact(p, x, hand, vel, &pen, &fx);
    z[0] = fabs(x[2]) - R(VR_STICK_BAND);
    z[1] = fabs(x[3]) - R(VR_STICK_BAND);
    z[2] = pen;
}

static void outputs(Plant *p) {
    const double *x = &p->r[VR_STATE0];
    double hand[2], vel[2], pen, fx;
    contact(p, x, hand, vel, &pen, &fx);
    R(VR_Q_1) = x[0];
    R(VR_Q_2) = x[1];
    R(VR_QD_1) = x[2];
    R(VR_QD_2) = x[3];
    R(VR_F_1) = -R(VR_KW) * x[4];
    R(VR_F_2) = -R(VR_KW) * x[5];
    R(VR_X_HAND_1) = hand[0];
    R(VR_X_HAND_2) = hand[1];
    R(VR_FX) = fx;
    R(VR_CONTACT) = pen > 0.0 ? 1.0 : 0.0;
    event_indicators(p, x, &p->r[VR_INDICATOR_1]);
    derivatives(p, x, &p->r[VR_DER0]);
}

/* the initial endpoint C-X: given, or where the wrist and surface springs in series carry the preload */
static double start_x(Plant *p) {
    if (R(VR_BALANCE) == 0.0) return R(VR_ENDPOINT0_1);
    return R(VR_SURFACE_X0) + R(VR_PRELOAD) * (1.0 / R(VR_KR) + 1.0 / R(VR_KW));
}

static int initial_state(Plant *p) {
    double X = start_x(p), Y = R(VR_ENDPOINT0_2), l = R(VR_L);
    double r2 = X * X + Y * Y - l * l, q1, q2;
    double *x = &p->r[VR_STATE0];
    if (r2 <= 0.0) return 0;
    q2 = sqrt(r2);
    q1 = atan2(Y, X) + atan2(l, q2); /* inverse kinematics (docs/model.md) */
    x[0] = q1;
    x[1] = q2;
    x[2] = x[3] = 0.0;
    x[4] = -R(VR_PRELOAD) * cos(q1) / R(VR_KW); /* hand in balance at the preload */
    x[5] = R(VR_PRELOAD) * sin(q1) / R(VR_KW);
    x[6] = x[7] = 0.0;
    return 1;
}

static void rk4(Plant *p, double h) {
    double *x = &p->r[VR_STATE0], k1[N_STATES], k2[N_STATES], k3[N_STATES], k4[N_STATES], y[N_STATES];
    int i;
    derivatives(p, x, k1);
    for (i = 0; i < N_STATES; i++) y[i] = x[i] + 0.5 * h * k1[i];
    derivatives(p, y, k2);
    for (i = 0; i < N_STATES; i++) y[i] = x[i] + 0.5 * h * k2[i];
    derivatives(p, y, k3);
    for (i = 0; i < N_STATES; i++) y[i] = x[i] + h * k3[i];
    derivatives(p, y, k4);
    for (i = 0; i < N_STATES; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
}

/* one co-simulation step of h: RK4 in equal substeps no longer than max_substep, inputs held.
 * Returns the index of a diverged state, or -1. */
static int cs_step(Plant *p, double h) {
    double *x = &p->r[VR_STATE0];
    int k, n = (int)ceil(h / R(VR_MAX_SUBSTEP) - 1e-9);
    if (n < 1) n = 1;
    for (k = 0; k < n; k++) rk4(p, h / n);
    for (k = 0; k < N_STATES; k++)
        if (!isfinite(x[k]) || fabs(x[k]) > 1e6) return k;
    return -1;
}

/* the parameters exitInitializationMode checks; the message, or NULL when they are fine */
static const char *bad_parameters(Plant *p, char *msg, size_t size) {
    int k;
    for (k = 0; k < N_VARS; k++) {  /* every parameter with a min in the model description */
        if (!isfinite(p->r[k])) {
            snprintf(msg, size, "%s = %g: not a finite number", VAR_NAMES[k], p->r[k]);
            return msg;
        }
        if (MIN_KIND[k] == 2 && !(p->r[k] > 0.0)) {
            snprintf(msg, size, "%s = %g must be positive", VAR_NAMES[k], p->r[k]);
            return msg;
        }
        if (MIN_KIND[k] == 1 && !(p->r[k] >= 0.0)) {
            snprintf(msg, size, "%s = %g must not be negative", VAR_NAMES[k], p->r[k]);
            return msg;
        }
    }
    if (R(VR_BALANCE) != 0.0 && R(VR_KR) <= 0.0)
        return "balance = 1 needs a positive Kr (the start is where the springs carry the preload)";
    if (!initial_state(p)) {
        snprintf(msg, size, "endpoint0 (%g, %g) lies within the link offset of the base",
                 start_x(p), R(VR_ENDPOINT0_2));
        return msg;
    }
    return NULL;
}

/* before a read: outputs from the state (in initialization mode, the start state of the parameters so far) */
static void refresh(Plant *p) {
    if (p->mode == MODE_INIT) initial_state(p);
    if (p->mode != MODE_INSTANTIATED) outputs(p);
}

/* the message refusing a non-finite value for variable vr, or NULL when the value is finite */
static const char *not_finite(unsigned int vr, double value, char *msg, size_t size) {
    if (isfinite(value)) return NULL;
    snprintf(msg, size, "%s = %g: not a finite number (refused)", VAR_NAMES[vr], value);
    return msg;
}

/* whether value reference vr is a fixed parameter that can no longer change (initialization is over) */
static int frozen(const Plant *p, unsigned int vr) {
    return FIXED[vr] && p->mode != MODE_INSTANTIATED && p->mode != MODE_INIT;
}

static const double NOMINALS[N_STATES] = {1.0, 1.0, 1.0, 1.0, 1e-5, 1e-5, 1e-2, 1e-2};

#endif
