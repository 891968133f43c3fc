/* Van der Pol oscillator as an FMI 3.0 FMU (ME and CS), written apart from the
 * hybridsim plant to test importing FMI 3.0. Only the functions an importer
 * calls for these interfaces are defined. Value references: 0 x, 1 der(x),
 * 2 v, 3 der(v), 4 mu, 5 y (output = x), 6 time, 7 t_stop (a Co-Simulation step past
 * it ends with terminateSimulation). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

typedef struct { double r[8]; double t; } VdP;

static void rhs(const double *r, double x, double v, double *dx, double *dv) {
    *dx = v;
    *dv = r[4] * (1.0 - x * x) * v - x;
}

static fmi3Instance make(void) {
    VdP *m = (VdP *)calloc(1, sizeof(VdP));
    if (m) { m->r[0] = 2.0; m->r[4] = 1.0; m->r[7] = 1e30; }
    return m;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                          fmi3Boolean log, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback cb) {
    (void)n; (void)tok; (void)res; (void)vis; (void)log; (void)env; (void)cb;
    return make();
}
fmi3Instance fmi3InstantiateCoSimulation(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                         fmi3Boolean log, fmi3Boolean evm, fmi3Boolean early,
                                         const fmi3ValueReference req[], size_t nreq,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback cb,
                                         fmi3IntermediateUpdateCallback up) {
    (void)n; (void)tok; (void)res; (void)vis; (void)log; (void)evm; (void)early; (void)req; (void)nreq;
    (void)env; (void)cb; (void)up;
    return make();
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean a, fmi3Float64 b, fmi3Float64 t0,
                                       fmi3Boolean d, fmi3Float64 e) {
    (void)a; (void)b; (void)d; (void)e;
    ((VdP *)c)->t = t0;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    VdP *m = (VdP *)c;
    size_t i;
    (void)nv;
    rhs(m->r, m->r[0], m->r[2], &m->r[1], &m->r[3]);
    m->r[5] = m->r[0];
    for (i = 0; i < n; i++) {
        if (vr[i] > 7) return fmi3Error;
        v[i] = vr[i] == 6 ? m->t : m->r[vr[i]];
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] > 7 || vr[i] == 6) return fmi3Error; ((VdP *)c)->r[vr[i]] = v[i]; }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *a, fmi3Boolean *b, fmi3Boolean *d,
                                    fmi3Boolean *e, fmi3Boolean *f, fmi3Float64 *g) {
    (void)c;
    *a = *b = *d = *e = *f = fmi3False;
    *g = 0.0;
    return fmi3OK;
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((VdP *)c)->t = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi3Error;
    m->r[0] = x[0]; m->r[2] = x[1];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi3Error;
    x[0] = m->r[0]; x[1] = m->r[2];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n) {
    VdP *m = (VdP *)c;
    if (n != 2) return fmi3Error;
    rhs(m->r, m->r[0], m->r[2], &d[0], &d[1]);
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) { (void)c; (void)z; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean p, fmi3Boolean *ev,
                      fmi3Boolean *term, fmi3Boolean *early, fmi3Float64 *last) {
    VdP *m = (VdP *)c;
    int k, n = (int)ceil(h / 1e-3);
    double dt = h / n, x, v, a1, b1, a2, b2, a3, b3, a4, b4;
    (void)p;
    *ev = *early = fmi3False;
    if (t + h > m->r[7] + 1e-12) {  /* asks the importer to stop, having done nothing */
        *term = fmi3True;
        *last = t;
        return fmi3OK;
    }
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
    *ev = *term = *early = fmi3False;
    *last = m->t;
    return fmi3OK;
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean nos, fmi3Boolean *enter, fmi3Boolean *term) {
    (void)c; (void)nos;
    *enter = *term = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 2; return fmi3OK; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    (void)c;
    if (n != 2) return fmi3Error;
    x[0] = x[1] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}
const char *fmi3GetVersion(void) { return fmi3Version; }
