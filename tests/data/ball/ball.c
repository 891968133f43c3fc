/* A bouncing ball with a stair counter, as an FMI 2.0 Model Exchange FMU: a state event with a
 * reset (h falls through 0: v <- -e v) and time events (count steps up at t = 1, 2, 3, ... s).
 * Written for hybridsim's tests of the FMI event protocol.
 * At t_stop (a parameter) it asks to terminate the simulation (terminateSimulation).
 * Variables: 0 h, 1 der(h), 2 v, 3 der(v), 4 e, 5 g, 6 height (output = h), 7 count (output),
 * 8 t_stop; Integer 9 bounces, 11 k_in (input), 12 k_out = k_in + 1; Boolean 10 up (v > 0),
 * 13 flag_in (input), 14 flag_out = !flag_in: ports of other types than Real;
 * String 15 label (parameter, start "ab") and Integer 16 label_length = strlen(label). */
#include <math.h>
#include <float.h>
#include <string.h>
#include "fmi2Functions.h"

typedef struct { double r[9]; double t, next; int bounces, k_in, flag_in, event_mode, label_len; fmi2CallbackFunctions cb; } Ball;

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String g, fmi2String r,
                              const fmi2CallbackFunctions *cb, fmi2Boolean v, fmi2Boolean l) {
    Ball *m = (Ball *)cb->allocateMemory(1, sizeof(Ball));
    (void)n; (void)t; (void)g; (void)r; (void)v; (void)l;
    m->cb = *cb;
    m->r[0] = 1.0; m->r[2] = 0.0; m->r[4] = 0.7; m->r[5] = 9.81; m->r[7] = 0.0; m->r[8] = 1e30; m->label_len = 2;
    m->t = 0.0; m->next = 1.0; m->bounces = 0; m->k_in = 0; m->flag_in = 0; m->event_mode = 1;
    return m;
}
void fmi2FreeInstance(fmi2Component c) { ((Ball *)c)->cb.freeMemory(c); }
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Ball *m = (Ball *)c;
    size_t i;
    m->r[1] = m->r[2]; m->r[3] = -m->r[5]; m->r[6] = m->r[0];
    for (i = 0; i < n; i++) { if (vr[i] > 8) return fmi2Error; v[i] = m->r[vr[i]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    size_t i;
    for (i = 0; i < n; i++) { if (vr[i] > 8) return fmi2Error; ((Ball *)c)->r[vr[i]] = v[i]; }
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Ball *)c)->t = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi2Error;
    m->r[0] = x[0]; m->r[2] = x[1];
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi2Error;
    x[0] = m->r[0]; x[1] = m->r[2];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi2Error;
    d[0] = m->r[2]; d[1] = -m->r[5];
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    if (n != 1) return fmi2Error;
    z[0] = ((Ball *)c)->r[0];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c; x[0] = x[1] = 1.0; return n == 2 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Ball *m = (Ball *)c;
    memset(e, 0, sizeof *e);
    if (m->r[0] <= 0.0 && m->r[2] < 0.0) {  /* the bounce */
        m->r[0] = DBL_MIN;  /* just above the floor: in z > 0, FMI's other domain than z <= 0 */
        m->r[2] = -m->r[4] * m->r[2];
        m->bounces += 1;
        e->valuesOfContinuousStatesChanged = fmi2True;
    }
    if (m->t >= m->next - 1e-12) {  /* a step of the stairs */
        m->r[7] += 1.0;
        m->next += 1.0;
    }
    if (m->t >= m->r[8] - 1e-12) e->terminateSimulation = fmi2True;
    e->nextEventTimeDefined = fmi2True;
    e->nextEventTime = m->next < m->r[8] ? m->next : m->r[8];
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Ball *m = (Ball *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == 9) v[i] = m->bounces;
        else if (vr[i] == 11) v[i] = m->k_in;
        else if (vr[i] == 12) v[i] = m->k_in + 1;
        else if (vr[i] == 16) v[i] = m->label_len;
        else return fmi2Error;
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    size_t i;
    if (!((Ball *)c)->event_mode) return fmi2Error; /* a discrete-time input: event mode only */
    for (i = 0; i < n; i++) { if (vr[i] != 11) return fmi2Error; ((Ball *)c)->k_in = v[i]; }
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Ball *m = (Ball *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == 10) v[i] = m->r[2] > 0.0;
        else if (vr[i] == 13) v[i] = m->flag_in;
        else if (vr[i] == 14) v[i] = !m->flag_in;
        else return fmi2Error;
    }
    return fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    size_t i;
    if (!((Ball *)c)->event_mode) return fmi2Error; /* a discrete-time input: event mode only */
    for (i = 0; i < n; i++) { if (vr[i] != 13) return fmi2Error; ((Ball *)c)->flag_in = v[i] != 0; }
    return fmi2OK;
}
fmi2Status fmi2EnterEventMode(fmi2Component c) { ((Ball *)c)->event_mode = 1; return fmi2OK; }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { ((Ball *)c)->event_mode = 0; return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean s, fmi2Boolean *e, fmi2Boolean *t) {
    (void)c; (void)s; *e = fmi2False; *t = fmi2False; return fmi2OK;
}

#define OK_STUB(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2OK; }
#define ERR_STUB(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2Error; }
OK_STUB(fmi2SetDebugLogging, fmi2Component c, fmi2Boolean l, size_t n, const fmi2String s[])
OK_STUB(fmi2SetupExperiment, fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real d, fmi2Boolean e, fmi2Real f)
OK_STUB(fmi2EnterInitializationMode, fmi2Component c)
OK_STUB(fmi2ExitInitializationMode, fmi2Component c)
OK_STUB(fmi2Terminate, fmi2Component c)
OK_STUB(fmi2Reset, fmi2Component c)
ERR_STUB(fmi2DoStep, fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean p)
ERR_STUB(fmi2GetString, fmi2Component c, const fmi2ValueReference r[], size_t n, fmi2String v[])
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    size_t i;
    for (i = 0; i < n; i++) { if (vr[i] != 15 || !v[i]) return fmi2Error; ((Ball *)c)->label_len = (int)strlen(v[i]); }
    return fmi2OK;
}
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
