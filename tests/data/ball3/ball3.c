/* The bouncing ball with a stair counter (see ../ball/ball.c) as an FMI 3.0 Model Exchange
 * FMU: a state event with a reset, time events at t = 1, 2, ... s, terminateSimulation at
 * t_stop, and Int32/Boolean ports. The functions it does not define are added by hybridsim.fmi.build_fmu.
 * Value references: 0 h, 1 der(h), 2 v, 3 der(v), 4 e, 5 g, 6 height, 7 count, 8 t_stop, 9 time;
 * Int32 10 bounces, 11 k_in (input), 12 k_out = k_in + 1; Boolean 13 flag_in (input),
 * 14 flag_out = !flag_in; String 15 label (parameter), Int32 16 label_length = strlen(label),
 * Binary 17 blob (parameter), Int32 18 blob_sum = the sum of its bytes. */
#include <stdlib.h>
#include <float.h>
#include <string.h>
#include "fmi3Functions.h"

typedef struct { double r[9]; double t, next; int bounces, k_in, flag_in, event_mode, label_len, blob_sum; } Ball;

static fmi3Instance make(void) {
    Ball *m = (Ball *)calloc(1, sizeof(Ball));
    if (m) { m->r[0] = 1.0; m->r[4] = 0.7; m->r[5] = 9.81; m->r[8] = 1e30; m->next = 1.0; m->event_mode = 1; m->label_len = 2; m->blob_sum = 3; }
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
    return NULL;  /* Model Exchange only */
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean a, fmi3Float64 b, fmi3Float64 t0,
                                       fmi3Boolean d, fmi3Float64 e) {
    (void)a; (void)b; (void)d; (void)e;
    ((Ball *)c)->t = t0;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Ball *m = (Ball *)c;
    size_t i;
    (void)nv;
    m->r[1] = m->r[2]; m->r[3] = -m->r[5]; m->r[6] = m->r[0];
    for (i = 0; i < n; i++) {
        if (vr[i] > 9) return fmi3Error;
        v[i] = vr[i] == 9 ? m->t : m->r[vr[i]];
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] > 8) return fmi3Error; ((Ball *)c)->r[vr[i]] = v[i]; }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    Ball *m = (Ball *)c;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] == 10) v[i] = m->bounces;
        else if (vr[i] == 11) v[i] = m->k_in;
        else if (vr[i] == 12) v[i] = m->k_in + 1;
        else if (vr[i] == 16) v[i] = m->label_len;
        else if (vr[i] == 18) v[i] = m->blob_sum;
        else return fmi3Error;
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Int32 v[], size_t nv) {
    size_t i;
    (void)nv;
    if (!((Ball *)c)->event_mode) return fmi3Error; /* a discrete-time input: event mode only */
    for (i = 0; i < n; i++) { if (vr[i] != 11) return fmi3Error; ((Ball *)c)->k_in = v[i]; }
    return fmi3OK;
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3String v[], size_t nv) {
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 15 || !v[i]) return fmi3Error; ((Ball *)c)->label_len = (int)strlen(v[i]); }
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary v[], size_t nv) {
    size_t i, k;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] != 17) return fmi3Error;
        ((Ball *)c)->blob_sum = 0;
        for (k = 0; k < sizes[i]; k++) ((Ball *)c)->blob_sum += v[i][k];
    }
    return fmi3OK;
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) {
    Ball *m = (Ball *)c;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] == 13) v[i] = m->flag_in;
        else if (vr[i] == 14) v[i] = !m->flag_in;
        else return fmi3Error;
    }
    return fmi3OK;
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Boolean v[], size_t nv) {
    size_t i;
    (void)nv;
    if (!((Ball *)c)->event_mode) return fmi3Error; /* a discrete-time input: event mode only */
    for (i = 0; i < n; i++) { if (vr[i] != 13) return fmi3Error; ((Ball *)c)->flag_in = v[i] != 0; }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *need, fmi3Boolean *term, fmi3Boolean *nom,
                                    fmi3Boolean *values, fmi3Boolean *defined, fmi3Float64 *next) {
    Ball *m = (Ball *)c;
    *need = *term = *nom = *values = fmi3False;
    if (m->r[0] <= 0.0 && m->r[2] < 0.0) {  /* the bounce */
        m->r[0] = DBL_MIN;  /* just above the floor: in z > 0, FMI's other domain than z <= 0 */
        m->r[2] = -m->r[4] * m->r[2];
        m->bounces += 1;
        *values = fmi3True;
    }
    if (m->t >= m->next - 1e-12) { m->r[7] += 1.0; m->next += 1.0; }  /* a step of the stairs */
    if (m->t >= m->r[8] - 1e-12) *term = fmi3True;
    *defined = fmi3True;
    *next = m->next < m->r[8] ? m->next : m->r[8];
    return fmi3OK;
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { ((Ball *)c)->event_mode = 0; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3Error; }
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Ball *)c)->t = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi3Error;
    m->r[0] = x[0]; m->r[2] = x[1];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi3Error;
    x[0] = m->r[0]; x[1] = m->r[2];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n) {
    Ball *m = (Ball *)c;
    if (n != 2) return fmi3Error;
    d[0] = m->r[2]; d[1] = -m->r[5];
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    if (n != 1) return fmi3Error;
    z[0] = ((Ball *)c)->r[0];
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean p, fmi3Boolean *ev,
                      fmi3Boolean *term, fmi3Boolean *early, fmi3Float64 *last) {
    (void)c; (void)t; (void)h; (void)p; (void)ev; (void)term; (void)early; (void)last;
    return fmi3Error;
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean nos, fmi3Boolean *enter, fmi3Boolean *term) {
    (void)c; (void)nos;
    *enter = *term = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 2; return fmi3OK; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 1; return fmi3OK; }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    (void)c;
    if (n != 2) return fmi3Error;
    x[0] = x[1] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Ball *)c)->event_mode = 1; return fmi3OK; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}
const char *fmi3GetVersion(void) { return fmi3Version; }
