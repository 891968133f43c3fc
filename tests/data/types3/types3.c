/* An FMI 3.0 Model Exchange FMU with an output of every numeric type, for the bound output
 * getters (hybridsim.fmi.calls): one state x' = 1 from x(0) = 0, and
 *   2 f64 = 1.5 + x          3 f32 = 0.25 + x (Float32)
 *   4 i8  = -100 + (int)(10 x)        5 u8  = 200 + (int)(10 x)
 *   6 i16 = -30000 + (int)(1000 x)    7 u16 = 60000 + (int)(1000 x)
 *   8 i32 = -2000000000 + (int)(1e6 x)     9 u32 = 4000000000 + (int)(1e6 x)
 *  10 i64 = -2^40 - (int)(1e6 x)     11 u64 = 2^40 + (int)(1e6 x)
 *  12 on  = x > 0.5 (Boolean)        13 mode = 1 + (x > 0.5) (Enumeration)
 * Value references 0 x, 1 der(x). The functions it does not define are added by
 * hybridsim.fmi.build_fmu. */
#include <stdlib.h>
#include "fmi3Functions.h"

typedef struct { double x, t; } Types;

fmi3Instance fmi3InstantiateModelExchange(fmi3String n, fmi3String tok, fmi3String res, fmi3Boolean vis,
                                          fmi3Boolean log, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback cb) {
    (void)n; (void)tok; (void)res; (void)vis; (void)log; (void)env; (void)cb;
    return calloc(1, sizeof(Types));
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean a, fmi3Float64 b, fmi3Float64 t0,
                                       fmi3Boolean d, fmi3Float64 e) {
    (void)a; (void)b; (void)d; (void)e;
    ((Types *)c)->t = t0;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *need, fmi3Boolean *term, fmi3Boolean *nom,
                                    fmi3Boolean *values, fmi3Boolean *defined, fmi3Float64 *next) {
    (void)c; (void)next;
    *need = *term = *nom = *values = *defined = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean nos, fmi3Boolean *enter, fmi3Boolean *term) {
    (void)c; (void)nos;
    *enter = *term = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Types *)c)->t = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    if (n != 1) return fmi3Error;
    ((Types *)c)->x = x[0];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    if (n != 1) return fmi3Error;
    x[0] = ((Types *)c)->x;
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n) {
    (void)c;
    if (n != 1) return fmi3Error;
    d[0] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 1; return fmi3OK; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    (void)c;
    if (n != 1) return fmi3Error;
    x[0] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    (void)c; (void)z;
    return n == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetFloat32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float32 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 3) return fmi3Error; v[i] = (fmi3Float32)(0.25 + x); }
    return fmi3OK;
}
fmi3Status fmi3GetInt8(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int8 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 4) return fmi3Error; v[i] = (fmi3Int8)(-100 + (int)(10 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetUInt8(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt8 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 5) return fmi3Error; v[i] = (fmi3UInt8)(200 + (int)(10 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetInt16(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int16 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 6) return fmi3Error; v[i] = (fmi3Int16)(-30000 + (int)(1000 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetUInt16(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt16 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 7) return fmi3Error; v[i] = (fmi3UInt16)(60000 + (int)(1000 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 8) return fmi3Error; v[i] = (fmi3Int32)(-2000000000 + (int)(1e6 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt32 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 9) return fmi3Error; v[i] = (fmi3UInt32)(4000000000u + (unsigned)(1e6 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetUInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt64 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 11) return fmi3Error; v[i] = (fmi3UInt64)((1ULL << 40) + (unsigned long long)(1e6 * x)); }
    return fmi3OK;
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) { if (vr[i] != 12) return fmi3Error; v[i] = (fmi3Boolean)(x > 0.5); }
    return fmi3OK;
}
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    double x = ((Types *)c)->x;
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] == 0) v[i] = x;
        else if (vr[i] == 1) v[i] = 1.0;
        else if (vr[i] == 2) v[i] = 1.5 + x;
        else return fmi3Error;
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int64 v[], size_t nv) {
    double x = ((Types *)c)->x;  /* Int64 10 and the Enumeration 13 (read as Int64) */
    size_t i;
    (void)nv;
    for (i = 0; i < n; i++) {
        if (vr[i] == 10) v[i] = -(1LL << 40) - (long long)(1e6 * x);
        else if (vr[i] == 13) v[i] = 1 + (x > 0.5);
        else return fmi3Error;
    }
    return fmi3OK;
}
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi3OK;
}
const char *fmi3GetVersion(void) { return fmi3Version; }
