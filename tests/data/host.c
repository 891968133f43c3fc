/* A plain C host for the plant FMU: no Python. Loads the binary extracted
 * from the FMU, runs it as Co-Simulation for 0.5 s at 60 Hz holding the
 * preload's torque, and prints the contact force. Usage: host LIB GUID */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env; (void)status; (void)category;
    va_start(args, message);
    fprintf(stderr, "[%s] ", name);
    vfprintf(stderr, message, args);
    fprintf(stderr, "\n");
    va_end(args);
}

#define LOAD(name) fmi2##name##TYPE *name = (fmi2##name##TYPE *)dlsym(lib, "fmi2" #name); \
    if (!name) { fprintf(stderr, "missing fmi2" #name "\n"); return 2; }

int main(int argc, char **argv) {
    void *lib;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c;
    fmi2ValueReference vr_tau2 = 1, vr_fx = 12;
    fmi2Real tau2 = 9.52036156, fx = 0.0;
    int k;
    if (argc < 3) return 2;
    lib = dlopen(argv[1], RTLD_NOW);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    LOAD(Instantiate) LOAD(SetupExperiment) LOAD(EnterInitializationMode) LOAD(ExitInitializationMode)
    LOAD(SetReal) LOAD(GetReal) LOAD(DoStep) LOAD(Terminate) LOAD(FreeInstance)
    c = Instantiate("host", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
    if (!c) return 3;
    SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
    EnterInitializationMode(c);
    ExitInitializationMode(c);
    SetReal(c, &vr_tau2, 1, &tau2);
    for (k = 0; k < 30; k++) {
        if (DoStep(c, k / 60.0, 1.0 / 60.0, fmi2True) != fmi2OK) return 4;
    }
    GetReal(c, &vr_fx, 1, &fx);
    printf("fx %.9f\n", fx);
    Terminate(c);
    FreeInstance(c);
    return 0;
}
