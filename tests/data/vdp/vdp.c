/* Van der Pol oscillator, x'' - mu (1 - x^2) x' + x = 0, as an FMI 2.0 FMU
 * (ME and CS). Written apart from the hybridsim plant to test importing a
 * foreign FMU. Variables: 0 x, 1 der(x), 2 v, 3 der(v), 4 mu, 5 y (output = x), 6 t_stop (a
 * Co-Simulation step past it is discarded: the FMU asks to stop). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

typedef struct { double r[7]; double t; fmi2CallbackFunctions cb; } VdP;

static void rhs(const double *r, double x, double v, double *dx, double *dv) {
    *dx = v;
    *dv = r[4] * (1.0 - x * x) * v - x;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String g, fmi2String r,
                              const fmi2CallbackFunctions *cb, fmi2Boolean v, fmi2Boolean l) {
    VdP *m = (VdP *)cb->allocateMemory(1, sizeof(VdP));
    (void)n; (void)t; (void)g; (void)r; (void)v; (void)l;
    m->cb = *cb;
    m->r[0] = 2.0; m->r[2] = 0.0; m->r[4] = 1.0; m->r[6] = 1e30;
    return m;
}
void fmi2FreeInstance(fmi2Component c) { ((VdP *)c)->cb.freeMemory(c); }
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    VdP *m = (VdP *)c;
    size_t i;
    rhs(m->r, m->r[0], m->r[2], &m->r[1], &m->r[3]);
    m->r[5] = m->r[0];
    for (i = 0; i < n; i++) { if (vr[i] > 6) return fmi2Error; v[i] = m->r[vr[i]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    size_t i;
    for (i = 0; i < n; i++) { if (vr[i] > 6) return fmi2Error; ((VdP *)c)->r[vr[i]] = v[i]; }
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((VdP *)c)->t = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi2Error;
    m->r[0] = x[0]; m->r[2] = x[1];
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi2Error;
    x[0] = m->r[0]; x[1] = m->r[2];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi2Error;
    rhs(m->r, m->r[0], m->r[2], &d[0], &d[1]);
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c; x[0] = x[1] = 1.0; return n == 2 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    (void)c; memset(e, 0, sizeof *e); return fmi2OK;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean s, fmi2Boolean *e, fmi2Boolean *t) {
    (void)c; (void)s; *e = fmi2False; *t = fmi2False; return fmi2OK;
}
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean p) {
    VdP *m = (VdP *)c;
    int k, n = (int)ceil(h / 1e-3);
    double dt = h / n, x, v, a1, b1, a2, b2, a3, b3, a4, b4;
    (void)p;
    if (t + h > m->r[6] + 1e-12) return fmi2Discard;  /* asks the importer to stop */
    for (k = 0; k < n; k++) { /* classic RK4 */
        x = m->r[0]; v = m->r[2];
        rhs(m->r, x, v, &a1, &b1);
        rhs(m->r, x + dt / 2 * a1, v + dt / 2 * b1, &a2, &b2);
        rhs(m->r, x + dt / 2 * a2, v + dt / 2 * b2, &a3, &b3);
        rhs(m->r, x + dt * a3, v + dt * b3, &a4, &b4);
        m->r[0] = x + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
        m->r[2] = v + dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4);
    }
    m->t = t + h;
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
