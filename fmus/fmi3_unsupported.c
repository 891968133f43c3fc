/* The FMI 3.0 functions the plant FMU does not offer. An importer such as fmpy
 * binds every FMI function when it loads a binary, so each must exist; each
 * answers fmi3Error (3). Kept apart from plant3.c so that no prototype from
 * fmi3Functions.h conflicts with these argument-less definitions. */
int fmi3ActivateModelPartition(void) { return 3; }
int fmi3DeserializeFMUState(void) { return 3; }
int fmi3EnterConfigurationMode(void) { return 3; }
int fmi3EvaluateDiscreteStates(void) { return 3; }
int fmi3ExitConfigurationMode(void) { return 3; }
int fmi3GetAdjointDerivative(void) { return 3; }
int fmi3GetBinary(void) { return 3; }
int fmi3GetClock(void) { return 3; }
int fmi3GetDirectionalDerivative(void) { return 3; }
int fmi3GetFloat32(void) { return 3; }
int fmi3GetInt16(void) { return 3; }
int fmi3GetInt32(void) { return 3; }
int fmi3GetInt64(void) { return 3; }
int fmi3GetInt8(void) { return 3; }
int fmi3GetIntervalDecimal(void) { return 3; }
int fmi3GetIntervalFraction(void) { return 3; }
int fmi3GetNumberOfVariableDependencies(void) { return 3; }
int fmi3GetOutputDerivatives(void) { return 3; }
int fmi3GetShiftDecimal(void) { return 3; }
int fmi3GetShiftFraction(void) { return 3; }
int fmi3GetString(void) { return 3; }
int fmi3GetUInt16(void) { return 3; }
int fmi3GetUInt32(void) { return 3; }
int fmi3GetUInt64(void) { return 3; }
int fmi3GetUInt8(void) { return 3; }
int fmi3GetVariableDependencies(void) { return 3; }
void *fmi3InstantiateScheduledExecution(void) { return 0; /* not offered */ }
int fmi3SerializeFMUState(void) { return 3; }
int fmi3SerializedFMUStateSize(void) { return 3; }
int fmi3SetBinary(void) { return 3; }
int fmi3SetClock(void) { return 3; }
int fmi3SetFloat32(void) { return 3; }
int fmi3SetInt16(void) { return 3; }
int fmi3SetInt32(void) { return 3; }
int fmi3SetInt64(void) { return 3; }
int fmi3SetInt8(void) { return 3; }
int fmi3SetIntervalDecimal(void) { return 3; }
int fmi3SetIntervalFraction(void) { return 3; }
int fmi3SetShiftDecimal(void) { return 3; }
int fmi3SetShiftFraction(void) { return 3; }
int fmi3SetString(void) { return 3; }
int fmi3SetUInt16(void) { return 3; }
int fmi3SetUInt32(void) { return 3; }
int fmi3SetUInt64(void) { return 3; }
int fmi3SetUInt8(void) { return 3; }
