/*
 * hybridsim plant FMU (FMI 2.0, Model Exchange and Co-Simulation in one binary).
 *
 * The arm of Raibert & Craig (1981) with stick-slip friction (eqs 5, 6, 11),
 * the hand on the wrist force sensor (eqs 7, 8) and the unilateral reaction
 * surface (eq 9), as corrected in MODEL.md. The same equations as the Python
 * blocks in blocks/manipulator.py, blocks/wrist.py and blocks/surface.py.
 *
 * Every real variable lives in r[], indexed by its value reference
 * (plant_vars.h, generated with modelDescription.xml from fmus/plant_model.py).
 * Co-Simulation: fmi2DoStep integrates with classic RK4 in equal substeps no
 * longer than max_substep, inputs held over the step.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "plant_vars.h"

typedef enum { MODE_INSTANTIATED, MODE_INIT, MODE_EVENT, MODE_CONTINUOUS, MODE_STEP, MODE_TERMINATED } Mode;

typedef struct {
    double r[N_VARS];
    double time;
    Mode mode;
    int is_cs;
    char name[128];
    fmi2CallbackFunctions cb;
} Plant;

static void say(Plant *p, fmi2Status status, const char *category, const char *text) {
    if (p->cb.logger) p->cb.logger(p->cb.componentEnvironment, p->name, status, category, "%s", text);
}

#define R(v) (p->r[v])

/* ---- the model ---------------------------------------------------------- */

/* eq 11, Karnopp: slide above the band, else cancel F and bring v to rest, up to tau_s */
static double friction(const Plant *p, double v, double F, double m, int joint) {
    double tc = joint == 1 ? R(VR_TAU_C_1) : R(VR_TAU_C_2);
    double ts = joint == 1 ? R(VR_TAU_S_1) : R(VR_TAU_S_2);
    double b;
    if (R(VR_FRICTION) == 0.0) return 0.0;
    if (fabs(v) >= R(VR_STICK_BAND)) return v > 0 ? -tc : tc;
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
    derivatives(p, x, &p->r[VR_DER0]);
}

static int initial_state(Plant *p) {
    double X = R(VR_ENDPOINT0_1), Y = R(VR_ENDPOINT0_2), l = R(VR_L);
    double r2 = X * X + Y * Y - l * l, q1, q2;
    double *x = &p->r[VR_STATE0];
    if (r2 <= 0.0) return 0;
    q2 = sqrt(r2);
    q1 = atan2(Y, X) + atan2(l, q2); /* inverse kinematics (MODEL.md) */
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

/* ---- FMI 2.0: common ---------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    Plant *p;
    (void)resources; (void)visible; (void)logging;
    if (!cb || !cb->allocateMemory) return NULL;
    p = (Plant *)cb->allocateMemory(1, sizeof(Plant));
    if (!p) return NULL;
    p->cb = *cb;
    snprintf(p->name, sizeof p->name, "%s", name ? name : "plant");
    if (!guid || strcmp(guid, MODEL_GUID) != 0) {
        say(p, fmi2Error, "logStatusError", "GUID does not match this binary's modelDescription.xml");
        cb->freeMemory(p);
        return NULL;
    }
    memcpy(p->r, START_VALUES, sizeof p->r);
    p->is_cs = type == fmi2CoSimulation;
    p->mode = MODE_INSTANTIATED;
    return p;
}

void fmi2FreeInstance(fmi2Component c) {
    Plant *p = (Plant *)c;
    if (p) p->cb.freeMemory(p);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) {
    Plant *p = (Plant *)c;
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    p->time = start;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ((Plant *)c)->mode = MODE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Plant *p = (Plant *)c;
    char msg[160];
    if (R(VR_KW) <= 0.0 || R(VR_M3) <= 0.0 || R(VR_MAX_SUBSTEP) <= 0.0) {
        say(p, fmi2Error, "logStatusError", "Kw, M3 and max_substep must be positive");
        return fmi2Error;
    }
    if (!initial_state(p)) {
        snprintf(msg, sizeof msg, "endpoint0 (%g, %g) lies within the link offset of the base",
                 R(VR_ENDPOINT0_1), R(VR_ENDPOINT0_2));
        say(p, fmi2Error, "logStatusError", msg);
        return fmi2Error;
    }
    outputs(p);
    p->mode = p->is_cs ? MODE_STEP : MODE_EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ((Plant *)c)->mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Plant *p = (Plant *)c;
    memcpy(p->r, START_VALUES, sizeof p->r);
    p->time = 0.0;
    p->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Plant *p = (Plant *)c;
    size_t i;
    if (p->mode == MODE_INIT) initial_state(p); /* the initial state of the parameters as set so far */
    if (p->mode != MODE_INSTANTIATED) outputs(p);
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS) {
            say(p, fmi2Error, "logStatusError", "fmi2GetReal: unknown value reference");
            return fmi2Error;
        }
        value[i] = p->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Plant *p = (Plant *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS) {
            say(p, fmi2Error, "logStatusError", "fmi2SetReal: unknown value reference");
            return fmi2Error;
        }
        if (FIXED[vr[i]] && p->mode != MODE_INSTANTIATED && p->mode != MODE_INIT) {
            say(p, fmi2Error, "logStatusError", "fmi2SetReal: a fixed parameter cannot change after initialization");
            return fmi2Error;
        }
        p->r[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Plant *p = (Plant *)c;
    size_t i;
    if (p->mode == MODE_INIT) initial_state(p);
    if (p->mode != MODE_INSTANTIATED) outputs(p);
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS || !BOOLEAN[vr[i]]) {
            say(p, fmi2Error, "logStatusError", "fmi2GetBoolean: not a Boolean variable");
            return fmi2Error;
        }
        v[i] = p->r[vr[i]] != 0.0;
    }
    return fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    Plant *p = (Plant *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS || !BOOLEAN[vr[i]] || vr[i] == VR_CONTACT) {
            say(p, fmi2Error, "logStatusError", "fmi2SetBoolean: not a Boolean parameter");
            return fmi2Error;
        }
        if (FIXED[vr[i]] && p->mode != MODE_INSTANTIATED && p->mode != MODE_INIT) {
            say(p, fmi2Error, "logStatusError", "fmi2SetBoolean: a fixed parameter cannot change after initialization");
            return fmi2Error;
        }
        p->r[vr[i]] = v[i] ? 1.0 : 0.0;
    }
    return fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)c; (void)vr; (void)v;
    return n == 0 ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Plant *p = (Plant *)c;
    Plant *copy = *state ? (Plant *)*state : (Plant *)p->cb.allocateMemory(1, sizeof(Plant));
    if (!copy) return fmi2Error;
    *copy = *p;
    *state = copy;
    return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    Plant *p = (Plant *)c;
    fmi2CallbackFunctions cb = p->cb;
    if (!state) return fmi2Error;
    *p = *(Plant *)state;
    p->cb = cb;
    return fmi2OK;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Plant *p = (Plant *)c;
    if (state && *state) p->cb.freeMemory(*state);
    if (state) *state = NULL;
    return fmi2OK;
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    (void)c; (void)s; (void)size;
    return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size) {
    (void)c; (void)s; (void)b; (void)size;
    return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t size, fmi2FMUstate *s) {
    (void)c; (void)b; (void)size; (void)s;
    return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[],
                                        fmi2Real dz[]) {
    (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return fmi2Error;
}

/* ---- Model Exchange ----------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    ((Plant *)c)->mode = MODE_EVENT;
    return fmi2OK;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    (void)c; /* friction and contact are functions of the state: no discrete state to update */
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    ((Plant *)c)->mode = MODE_CONTINUOUS;
    return fmi2OK;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter,
                                       fmi2Boolean *terminate) {
    (void)c; (void)noSet;
    *enter = fmi2False;
    *terminate = fmi2False;
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) {
    ((Plant *)c)->time = t;
    return fmi2OK;
}
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi2Error;
    memcpy(&p->r[VR_STATE0], x, sizeof(double) * N_STATES);
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi2Error;
    derivatives(p, &p->r[VR_STATE0], dx);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    Plant *p = (Plant *)c;
    const double *x = &p->r[VR_STATE0];
    double hand[2], vel[2], pen, fx;
    if (n != N_EVENT_INDICATORS) return fmi2Error;
    contact(p, x, hand, vel, &pen, &fx);
    z[0] = fabs(x[2]) - R(VR_STICK_BAND); /* joint 1 slide <-> stick */
    z[1] = fabs(x[3]) - R(VR_STICK_BAND); /* joint 2 slide <-> stick */
    z[2] = pen;                            /* contact make / break */
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi2Error;
    memcpy(x, &p->r[VR_STATE0], sizeof(double) * N_STATES);
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominal[], size_t n) {
    static const double nom[N_STATES] = {1.0, 1.0, 1.0, 1.0, 1e-5, 1e-5, 1e-2, 1e-2};
    (void)c;
    if (n != N_STATES) return fmi2Error;
    memcpy(nominal, nom, sizeof nom);
    return fmi2OK;
}

/* ---- Co-Simulation ------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)c; (void)vr; (void)n; (void)order; (void)value;
    return fmi2Error;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)c; (void)vr; (void)n; (void)order; (void)value;
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Plant *p = (Plant *)c;
    int k, n;
    double *x = &p->r[VR_STATE0];
    (void)noSetPrior;
    if (h < 0.0) {
        say(p, fmi2Error, "logStatusError", "fmi2DoStep: negative step size");
        return fmi2Error;
    }
    n = (int)ceil(h / R(VR_MAX_SUBSTEP) - 1e-9);
    if (n < 1) n = 1;
    for (k = 0; k < n; k++) rk4(p, h / n);
    for (k = 0; k < N_STATES; k++) {
        if (!isfinite(x[k]) || fabs(x[k]) > 1e6) {
            char msg[128];
            snprintf(msg, sizeof msg, "state %d diverged (%g) at t = %g s", k, x[k], t + h);
            say(p, fmi2Error, "logStatusError", msg);
            return fmi2Error;
        }
    }
    p->time = t + h;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    (void)c;
    return fmi2Error;
}
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    Plant *p = (Plant *)c;
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = p->time;
    return fmi2OK;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) {
    (void)c; (void)s; (void)v;
    return fmi2Discard;
}
