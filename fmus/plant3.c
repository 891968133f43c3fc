/*
 * hybridsim plant FMU, FMI 3.0 interface (Model Exchange and Co-Simulation in
 * one binary). The model is plant_core.h, the same as the FMI 2.0 interface
 * (plant.c); the FMI functions this FMU does not offer (clocks, other integer
 * types, strings, serialized state) are in fmi3_unsupported.c.
 */
#include "fmi3Functions.h"

typedef struct {
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} PlantCallbacks;
#include "plant_core.h"

static void say(Plant *p, fmi3Status status, const char *category, const char *text) {
    if (p->cb.log) p->cb.log(p->cb.env, status, category, text);
}

static Plant *make(fmi3String name, fmi3String token, fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                   int is_cs) {
    Plant *p = (Plant *)calloc(1, sizeof(Plant));
    if (!p) return NULL;
    p->cb.env = env;
    p->cb.log = log;
    snprintf(p->name, sizeof p->name, "%s", name ? name : "plant");
    if (!token || strcmp(token, MODEL_GUID) != 0) {
        say(p, fmi3Error, "logStatusError", "instantiationToken does not match this binary's modelDescription.xml");
        free(p);
        return NULL;
    }
    memcpy(p->r, START_VALUES, sizeof p->r);
    p->is_cs = is_cs;
    p->mode = MODE_INSTANTIATED;
    return p;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean visible,
                                          fmi3Boolean logging, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback log) {
    (void)res; (void)visible; (void)logging;
    return make(name, token, env, log, 0);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean visible,
                                         fmi3Boolean logging, fmi3Boolean eventMode, fmi3Boolean early,
                                         const fmi3ValueReference req[], size_t nreq,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                         fmi3IntermediateUpdateCallback update) {
    (void)res; (void)visible; (void)logging; (void)early; (void)req; (void)nreq; (void)update;
    if (eventMode) return NULL; /* no Co-Simulation event mode: the plant has no events to report */
    return make(name, token, env, log, 1);
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol, fmi3Float64 start,
                                       fmi3Boolean stopDef, fmi3Float64 stop) {
    Plant *p = (Plant *)c;
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    p->time = start;
    p->mode = MODE_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Plant *p = (Plant *)c;
    char msg[160];
    const char *bad = bad_parameters(p, msg, sizeof msg);
    if (bad) {
        say(p, fmi3Error, "logStatusError", bad);
        return fmi3Error;
    }
    outputs(p);
    p->mode = p->is_cs ? MODE_STEP : MODE_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    ((Plant *)c)->mode = MODE_EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance c) {
    ((Plant *)c)->mode = MODE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance c) {
    Plant *p = (Plant *)c;
    memcpy(p->r, START_VALUES, sizeof p->r);
    p->time = 0.0;
    p->mode = MODE_INSTANTIATED;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Plant *p = (Plant *)c;
    size_t i;
    if (nv != n) return fmi3Error; /* every variable of this FMU is a scalar */
    refresh(p);
    for (i = 0; i < n; i++) {
        if (vr[i] == VR_TIME) {
            v[i] = p->time;
        } else if (vr[i] >= N_VARS || BOOLEAN[vr[i]]) {
            say(p, fmi3Error, "logStatusError", "fmi3GetFloat64: not a Float64 variable");
            return fmi3Error;
        } else {
            v[i] = p->r[vr[i]];
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[],
                          size_t nv) {
    Plant *p = (Plant *)c;
    size_t i;
    char msg[160];
    const char *bad;
    if (nv != n) return fmi3Error;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS || BOOLEAN[vr[i]]) {
            say(p, fmi3Error, "logStatusError", "fmi3SetFloat64: not a Float64 variable");
            return fmi3Error;
        }
        if (frozen(p, vr[i])) {
            say(p, fmi3Error, "logStatusError", "fmi3SetFloat64: a fixed parameter cannot change after initialization");
            return fmi3Error;
        }
        if ((bad = not_finite(vr[i], v[i], msg, sizeof msg)) != NULL) {
            say(p, fmi3Error, "logStatusError", bad);
            return fmi3Error;
        }
        p->r[vr[i]] = v[i];
    }
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) {
    Plant *p = (Plant *)c;
    size_t i;
    if (nv != n) return fmi3Error;
    refresh(p);
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS || !BOOLEAN[vr[i]]) {
            say(p, fmi3Error, "logStatusError", "fmi3GetBoolean: not a Boolean variable");
            return fmi3Error;
        }
        v[i] = p->r[vr[i]] != 0.0;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Boolean v[],
                          size_t nv) {
    Plant *p = (Plant *)c;
    size_t i;
    if (nv != n) return fmi3Error;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS || !BOOLEAN[vr[i]] || vr[i] == VR_CONTACT) {
            say(p, fmi3Error, "logStatusError", "fmi3SetBoolean: not a Boolean parameter");
            return fmi3Error;
        }
        if (frozen(p, vr[i])) {
            say(p, fmi3Error, "logStatusError", "fmi3SetBoolean: a fixed parameter cannot change after initialization");
            return fmi3Error;
        }
        p->r[vr[i]] = v[i] ? 1.0 : 0.0;
    }
    return fmi3OK;
}

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state) {
    Plant *p = (Plant *)c;
    Plant *copy = *state ? (Plant *)*state : (Plant *)malloc(sizeof(Plant));
    if (!copy) return fmi3Error;
    *copy = *p;
    *state = copy;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    Plant *p = (Plant *)c;
    PlantCallbacks cb = p->cb;
    if (!state) return fmi3Error;
    *p = *(Plant *)state;
    p->cb = cb;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state) {
    (void)c;
    if (state && *state) free(*state);
    if (state) *state = NULL;
    return fmi3OK;
}

/* ---- Model Exchange ----------------------------------------------------- */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *need, fmi3Boolean *terminate,
                                    fmi3Boolean *nominals, fmi3Boolean *values, fmi3Boolean *defined,
                                    fmi3Float64 *next) {
    (void)c; /* friction and contact are functions of the state: no discrete state to update */
    *need = *terminate = *nominals = *values = *defined = fmi3False;
    *next = 0.0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    ((Plant *)c)->mode = MODE_CONTINUOUS;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSet, fmi3Boolean *enter,
                                       fmi3Boolean *terminate) {
    (void)c; (void)noSet;
    *enter = *terminate = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) {
    ((Plant *)c)->time = t;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi3Error;
    memcpy(&p->r[VR_STATE0], x, sizeof(double) * N_STATES);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi3Error;
    memcpy(x, &p->r[VR_STATE0], sizeof(double) * N_STATES);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi3Error;
    derivatives(p, &p->r[VR_STATE0], dx);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_EVENT_INDICATORS) return fmi3Error;
    event_indicators(p, &p->r[VR_STATE0], z);
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominal[], size_t n) {
    (void)c;
    if (n != N_STATES) return fmi3Error;
    memcpy(nominal, NOMINALS, sizeof NOMINALS);
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) {
    (void)c;
    *n = N_EVENT_INDICATORS;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) {
    (void)c;
    *n = N_STATES;
    return fmi3OK;
}

/* ---- Co-Simulation ------------------------------------------------------ */

fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    ((Plant *)c)->mode = MODE_STEP;
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
                      fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early,
                      fmi3Float64 *lastTime) {
    Plant *p = (Plant *)c;
    int bad;
    (void)noSetPrior;
    *eventNeeded = *terminate = *early = fmi3False;
    *lastTime = t;
    if (h < 0.0) {
        say(p, fmi3Error, "logStatusError", "fmi3DoStep: negative step size");
        return fmi3Error;
    }
    bad = cs_step(p, h);
    if (bad >= 0) {
        char msg[128];
        snprintf(msg, sizeof msg, "state %d diverged (%g) at t = %g s", bad, p->r[VR_STATE0 + bad], t + h);
        say(p, fmi3Error, "logStatusError", msg);
        return fmi3Error;
    }
    p->time = t + h;
    *lastTime = p->time;
    return fmi3OK;
}
