/* FMI 3.0 arrays, text and bytes, as a Co-Simulation FMU, to test importing them.
 * Value references: 0 time; 1 gains (parameter, Float64[3]); 2 u (input, Float64[3]);
 * 3 y (output, Float64[3]) = gains u + offs; 4 name (String input); 5 label (String
 * output: name and a counter of steps); 6 total (output) = sum(y) + len(name) + sum(blob);
 * 7..9 offs[0], offs[1], offs[2] (scalar parameters with 0-based element names);
 * 10 blob (Binary input). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

typedef struct {
    double t, gains[3], u[3], offs[3];
    char name[64], label[96];
    unsigned char blob[16];
    size_t nblob;
    int steps;
} Arr;

fmi3Instance fmi3InstantiateCoSimulation(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                         fmi3Boolean log, fmi3Boolean evm, fmi3Boolean early,
                                         const fmi3ValueReference req[], size_t nreq,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback cb,
                                         fmi3IntermediateUpdateCallback up) {
    Arr *m = (Arr *)calloc(1, sizeof(Arr));
    int i;
    (void)n; (void)tok; (void)res; (void)vis; (void)log; (void)evm; (void)early; (void)req; (void)nreq;
    (void)env; (void)cb; (void)up;
    if (!m) return NULL;
    for (i = 0; i < 3; i++) { m->gains[i] = i + 1; m->u[i] = 0.5; }
    strcpy(m->name, "abc");
    m->blob[0] = 1; m->blob[1] = 2; m->nblob = 2;
    return m;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean a, fmi3Float64 b, fmi3Float64 t0,
                                       fmi3Boolean d, fmi3Float64 e) {
    (void)a; (void)b; (void)d; (void)e;
    ((Arr *)c)->t = t0;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }

static double total(const Arr *m) {
    double s = (double)strlen(m->name);
    size_t i;
    for (i = 0; i < 3; i++) s += m->gains[i] * m->u[i] + m->offs[i];
    for (i = 0; i < m->nblob; i++) s += m->blob[i];
    return s;
}
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Arr *m = (Arr *)c;
    size_t i, k = 0, j;
    for (i = 0; i < n; i++) {
        size_t need = (vr[i] >= 1 && vr[i] <= 3) ? 3 : 1;
        if (k + need > nv) return fmi3Error;
        for (j = 0; j < need; j++, k++) {
            switch (vr[i]) {
                case 0: v[k] = m->t; break;
                case 1: v[k] = m->gains[j]; break;
                case 2: v[k] = m->u[j]; break;
                case 3: v[k] = m->gains[j] * m->u[j] + m->offs[j]; break;
                case 6: v[k] = total(m); break;
                case 7: case 8: case 9: v[k] = m->offs[vr[i] - 7]; break;
                default: return fmi3Error;
            }
        }
    }
    return k == nv ? fmi3OK : fmi3Error;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Arr *m = (Arr *)c;
    size_t i, k = 0, j;
    for (i = 0; i < n; i++) {
        if (vr[i] == 1 || vr[i] == 2) {
            if (k + 3 > nv) return fmi3Error;
            for (j = 0; j < 3; j++) (vr[i] == 1 ? m->gains : m->u)[j] = v[k++];
        } else if (vr[i] >= 7 && vr[i] <= 9) {
            if (k + 1 > nv) return fmi3Error;
            m->offs[vr[i] - 7] = v[k++];
        } else return fmi3Error;
    }
    return k == nv ? fmi3OK : fmi3Error;
}
fmi3Status fmi3GetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3String v[], size_t nv) {
    Arr *m = (Arr *)c;
    size_t i;
    if (n != nv) return fmi3Error;
    for (i = 0; i < n; i++) {
        if (vr[i] == 4) v[i] = m->name;
        else if (vr[i] == 5) { snprintf(m->label, sizeof m->label, "%s:%d", m->name, m->steps); v[i] = m->label; }
        else return fmi3Error;
    }
    return fmi3OK;
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3String v[], size_t nv) {
    Arr *m = (Arr *)c;
    (void)nv;
    if (n != 1 || vr[0] != 4 || !v[0] || strlen(v[0]) >= sizeof m->name) return fmi3Error;
    strcpy(m->name, v[0]);
    return fmi3OK;
}
fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, size_t sizes[],
                         fmi3Binary v[], size_t nv) {
    Arr *m = (Arr *)c;
    (void)nv;
    if (n != 1 || vr[0] != 10) return fmi3Error;
    sizes[0] = m->nblob; v[0] = m->blob;
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary v[], size_t nv) {
    Arr *m = (Arr *)c;
    (void)nv;
    if (n != 1 || vr[0] != 10 || sizes[0] > sizeof m->blob) return fmi3Error;
    memcpy(m->blob, v[0], sizes[0]); m->nblob = sizes[0];
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean p, fmi3Boolean *ev,
                      fmi3Boolean *term, fmi3Boolean *early, fmi3Float64 *last) {
    Arr *m = (Arr *)c;
    (void)p;
    m->t = t + h; m->steps++;
    *ev = *term = *early = fmi3False;
    *last = m->t;
    return fmi3OK;
}
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}
const char *fmi3GetVersion(void) { return fmi3Version; }
