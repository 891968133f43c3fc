/* A stair counter without continuous states, as an FMI 3.0 FMU (ME and CS), to test
 * importing FMUs that have none. Value references: 0 time, 1 counter (output, 1 at
 * t = 0, one more at every whole second: time events), 2 u (input), 3 y = gain u
 * (output, direct feedthrough; gain read from resources/gain.txt at instantiation),
 * 4 locked (input that refuses every write after instantiation), 5 limit (parameter,
 * min 1: the counter reaching it ends the run with terminateSimulation, the step done). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

typedef struct {
    double t, counter, u, gain, limit;
    int initialized;
    fmi3LogMessageCallback log;
    fmi3InstanceEnvironment env;
} Stair;

static void say(Stair *m, fmi3Status s, const char *msg) { if (m->log) m->log(m->env, s, "logStatusError", msg); }

static fmi3Instance make(fmi3String res, fmi3InstanceEnvironment env, fmi3LogMessageCallback cb) {
    char path[4096];
    FILE *f;
    Stair *m;
    snprintf(path, sizeof path, "%sgain.txt", res ? res : "");
    f = fopen(path, "r");
    if (!f) {
        if (cb) cb(env, fmi3Error, "logStatusError", "cannot open the resource file gain.txt");
        return NULL;
    }
    m = (Stair *)calloc(1, sizeof(Stair));
    if (m && fscanf(f, "%lf", &m->gain) != 1) { free(m); m = NULL; }
    fclose(f);
    if (!m) return NULL;
    m->counter = 1.0; m->limit = 1e9; m->u = 0.0; m->log = cb; m->env = env;
    return m;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                          fmi3Boolean log, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback cb) {
    (void)n; (void)tok; (void)vis; (void)log;
    return make(res, env, cb);
}
fmi3Instance fmi3InstantiateCoSimulation(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                         fmi3Boolean log, fmi3Boolean evm, fmi3Boolean early,
                                         const fmi3ValueReference req[], size_t nreq,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback cb,
                                         fmi3IntermediateUpdateCallback up) {
    (void)n; (void)tok; (void)vis; (void)log; (void)evm; (void)early; (void)req; (void)nreq; (void)up;
    return make(res, env, cb);
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean a, fmi3Float64 b, fmi3Float64 t0,
                                       fmi3Boolean d, fmi3Float64 e) {
    (void)a; (void)b; (void)d; (void)e;
    ((Stair *)c)->t = t0;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Stair *m = (Stair *)c;
    if (!(m->limit >= 1.0)) { say(m, fmi3Error, "limit must be at least 1"); return fmi3Error; }
    m->initialized = 1;
    return fmi3OK;
}
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Stair *m = (Stair *)c;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        switch (vr[i]) {
            case 0: v[i] = m->t; break;
            case 1: v[i] = m->counter; break;
            case 2: v[i] = m->u; break;
            case 3: v[i] = m->gain * m->u; break;
            case 4: v[i] = 0.0; break;
            case 5: v[i] = m->limit; break;
            default: return fmi3Error;
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Stair *m = (Stair *)c;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] == 2) m->u = v[i];
        else if (vr[i] == 4) { say(m, fmi3Error, "locked may not be written"); return fmi3Error; }
        else if (vr[i] == 5 && !m->initialized) m->limit = v[i];
        else return fmi3Error;
    }
    return fmi3OK;
}
/* the counter at time t: 1 + the whole seconds passed, up to the limit */
static void count(Stair *m, double t) {
    double k = 1.0 + floor(t + 1e-9);
    m->counter = k < m->limit ? k : m->limit;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needed, fmi3Boolean *term, fmi3Boolean *nom,
                                    fmi3Boolean *changed, fmi3Boolean *defined, fmi3Float64 *next) {
    Stair *m = (Stair *)c;
    double before = m->counter;
    count(m, m->t);
    *needed = *nom = fmi3False;
    *changed = fmi3False;  /* no continuous states to change */
    *term = m->counter >= m->limit;
    (void)before;
    *defined = fmi3True;
    *next = floor(m->t + 1e-9) + 1.0;
    return fmi3OK;
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Stair *)c)->t = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) { (void)c; (void)x; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) { (void)c; (void)x; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n) { (void)c; (void)d; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) { (void)c; (void)z; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean p, fmi3Boolean *ev,
                      fmi3Boolean *term, fmi3Boolean *early, fmi3Float64 *last) {
    Stair *m = (Stair *)c;
    (void)p;
    m->t = t + h;
    count(m, m->t);
    *ev = *early = fmi3False;
    *term = m->counter >= m->limit;  /* the step is done: the importer records it, then stops */
    *last = m->t;
    return fmi3OK;
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean nos, fmi3Boolean *enter, fmi3Boolean *term) {
    (void)c; (void)nos;
    *enter = *term = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) { (void)c; (void)x; return n == 0 ? fmi3OK : fmi3Error; }
fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}
const char *fmi3GetVersion(void) { return fmi3Version; }
