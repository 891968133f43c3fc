/*
 * hybridsim plant FMU, FMI 2.0 interface (Model Exchange and Co-Simulation in
 * one binary). The model is plant_core.h; plant3.c is the FMI 3.0 interface.
 * Co-Simulation: fmi2DoStep integrates with classic RK4 in equal substeps no
 * longer than max_substep, inputs held over the step.
 */
#include "fmi2Functions.h"

typedef fmi2CallbackFunctions PlantCallbacks;
#include "plant_core.h"

static void say(Plant *p, fmi2Status status, const char *category, const char *text) {
    if (p->cb.logger) p->cb.logger(p->cb.componentEnvironment, p->name, status, category, "%s", text);
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
    const char *bad = bad_parameters(p, msg, sizeof msg);
    if (bad) {
        say(p, fmi2Error, "logStatusError", bad);
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
    refresh(p);
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
    char msg[160];
    const char *bad;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VARS) {
            say(p, fmi2Error, "logStatusError", "fmi2SetReal: unknown value reference");
            return fmi2Error;
        }
        if (frozen(p, vr[i])) {
            say(p, fmi2Error, "logStatusError", "fmi2SetReal: a fixed parameter cannot change after initialization");
            return fmi2Error;
        }
        if ((bad = not_finite(vr[i], value[i], msg, sizeof msg)) != NULL) {
            say(p, fmi2Error, "logStatusError", bad);
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
    refresh(p);
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
        if (frozen(p, vr[i])) {
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
    if (n != N_EVENT_INDICATORS) return fmi2Error;
    event_indicators(p, &p->r[VR_STATE0], z);
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Plant *p = (Plant *)c;
    if (n != N_STATES) return fmi2Error;
    memcpy(x, &p->r[VR_STATE0], sizeof(double) * N_STATES);
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominal[], size_t n) {
    (void)c;
    if (n != N_STATES) return fmi2Error;
    memcpy(nominal, NOMINALS, sizeof NOMINALS);
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
    int bad;
    (void)noSetPrior;
    if (h < 0.0) {
        say(p, fmi2Error, "logStatusError", "fmi2DoStep: negative step size");
        return fmi2Error;
    }
    bad = cs_step(p, h);
    if (bad >= 0) {
        char msg[128];
        snprintf(msg, sizeof msg, "state %d diverged (%g) at t = %g s", bad, p->r[VR_STATE0 + bad], t + h);
        say(p, fmi2Error, "logStatusError", msg);
        return fmi2Error;
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
