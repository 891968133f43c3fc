/* A step-event counter as an FMI 2.0 Model Exchange FMU: x' = rate, and after an accepted
 * integrator step with x >= threshold, fmi2CompletedIntegratorStep asks for event mode, where
 * x is reset to 0 (a step event: no event indicator, no time event). It counts the calls of
 * fmi2CompletedIntegratorStep and the resets; past t_stop it asks to terminate.
 * Variables: 0 x, 1 der(x), 2 rate, 3 threshold, 4 y (= x), 5 calls, 6 resets, 7 t_stop. */
#include <string.h>
#include "fmi2Functions.h"

typedef struct { double r[8]; double t; int pending; fmi2CallbackFunctions cb; } Stepev;

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String g, fmi2String r,
                              const fmi2CallbackFunctions *cb, fmi2Boolean v, fmi2Boolean l) {
    Stepev *m = (Stepev *)cb->allocateMemory(1, sizeof(Stepev));
    (void)n; (void)t; (void)g; (void)r; (void)v; (void)l;
    m->cb = *cb;
    m->r[2] = 1.0; m->r[3] = 0.5005; m->r[7] = 1e30;
    return m;
}
void fmi2FreeInstance(fmi2Component c) { ((Stepev *)c)->cb.freeMemory(c); }
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Stepev *m = (Stepev *)c;
    size_t i;
    m->r[1] = m->r[2];
    m->r[4] = m->r[0];
    for (i = 0; i < n; i++) { if (vr[i] > 7) return fmi2Error; v[i] = m->r[vr[i]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    size_t i;
    for (i = 0; i < n; i++) { if (vr[i] > 7) return fmi2Error; ((Stepev *)c)->r[vr[i]] = v[i]; }
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Stepev *)c)->t = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    if (n != 1) return fmi2Error;
    ((Stepev *)c)->r[0] = x[0];
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    if (n != 1) return fmi2Error;
    x[0] = ((Stepev *)c)->r[0];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) {
    if (n != 1) return fmi2Error;
    d[0] = ((Stepev *)c)->r[2];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c; x[0] = 1.0; return n == 1 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean s, fmi2Boolean *e, fmi2Boolean *t) {
    Stepev *m = (Stepev *)c;
    (void)s;
    m->r[5] += 1.0;
    m->pending = m->r[0] >= m->r[3];
    *e = m->pending ? fmi2True : fmi2False;
    *t = m->t >= m->r[7] ? fmi2True : fmi2False;
    return fmi2OK;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Stepev *m = (Stepev *)c;
    memset(e, 0, sizeof *e);
    if (m->pending) {  /* the step event: reset the state */
        m->pending = 0;
        m->r[0] = 0.0;
        m->r[6] += 1.0;
        e->valuesOfContinuousStatesChanged = fmi2True;
    }
    return fmi2OK;
}

#define OK_STUB(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2OK; }
#define ERR_STUB(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2Error; }
OK_STUB(fmi2SetDebugLogging, fmi2Component c, fmi2Boolean l, size_t n, const fmi2String s[])
OK_STUB(fmi2SetupExperiment, fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real d, fmi2Boolean e, fmi2Real f)
OK_STUB(fmi2EnterInitializationMode, fmi2Component c)
OK_STUB(fmi2ExitInitializationMode, fmi2Component c)
OK_STUB(fmi2Terminate, fmi2Component c)
OK_STUB(fmi2Reset, fmi2Component c)
OK_STUB(fmi2EnterEventMode, fmi2Component c)
OK_STUB(fmi2EnterContinuousTimeMode, fmi2Component c)
OK_STUB(fmi2GetEventIndicators, fmi2Component c, fmi2Real z[], size_t n)
ERR_STUB(fmi2DoStep, fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean p)
ERR_STUB(fmi2GetInteger, fmi2Component c, const fmi2ValueReference r[], size_t n, fmi2Integer v[])
ERR_STUB(fmi2GetBoolean, fmi2Component c, const fmi2ValueReference r[], size_t n, fmi2Boolean v[])
ERR_STUB(fmi2GetString, fmi2Component c, const fmi2ValueReference r[], size_t n, fmi2String v[])
ERR_STUB(fmi2SetInteger, fmi2Component c, const fmi2ValueReference r[], size_t n, const fmi2Integer v[])
ERR_STUB(fmi2SetBoolean, fmi2Component c, const fmi2ValueReference r[], size_t n, const fmi2Boolean v[])
ERR_STUB(fmi2SetString, fmi2Component c, const fmi2ValueReference r[], size_t n, const fmi2String v[])
ERR_STUB(fmi2GetFMUstate, fmi2Component c, fmi2FMUstate *s)
ERR_STUB(fmi2SetFMUstate, fmi2Component c, fmi2FMUstate s)
ERR_STUB(fmi2FreeFMUstate, fmi2Component c, fmi2FMUstate *s)
ERR_STUB(fmi2SerializedFMUstateSize, fmi2Component c, fmi2FMUstate s, size_t *n)
ERR_STUB(fmi2SerializeFMUstate, fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
ERR_STUB(fmi2DeSerializeFMUstate, fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
ERR_STUB(fmi2GetDirectionalDerivative, fmi2Component c, const fmi2ValueReference a[], size_t na,
         const fmi2ValueReference b[], size_t nb, const fmi2Real d[], fmi2Real e[])
ERR_STUB(fmi2SetRealInputDerivatives, fmi2Component c, const fmi2ValueReference r[], size_t n,
         const fmi2Integer o[], const fmi2Real v[])
ERR_STUB(fmi2GetRealOutputDerivatives, fmi2Component c, const fmi2ValueReference r[], size_t n,
         const fmi2Integer o[], fmi2Real v[])
ERR_STUB(fmi2CancelStep, fmi2Component c)
ERR_STUB(fmi2GetStatus, fmi2Component c, const fmi2StatusKind k, fmi2Status *v)
ERR_STUB(fmi2GetRealStatus, fmi2Component c, const fmi2StatusKind k, fmi2Real *v)
ERR_STUB(fmi2GetIntegerStatus, fmi2Component c, const fmi2StatusKind k, fmi2Integer *v)
ERR_STUB(fmi2GetBooleanStatus, fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v)
ERR_STUB(fmi2GetStringStatus, fmi2Component c, const fmi2StatusKind k, fmi2String *v)
