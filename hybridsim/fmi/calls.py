"""A Model Exchange instance's continuous-time calls and output reads, bound once.

A right-hand side or root function calls the FMU a few thousand times per
simulated second; fmpy's wrappers (a Python method, argument arrays built,
a status check and logging hook per call) cost several times the C functions
themselves. :class:`BoundCalls` takes the same C functions from the FMU's
shared library, gives them their FMI signatures once, and calls them on
buffers allocated once; a status above warning becomes the ``FMICallException``
fmpy raises (function name and status).
"""
import ctypes

import numpy as np

_P, _N = ctypes.c_void_p, ctypes.c_size_t

#: (FMI 2.0 name, FMI 3.0 name) of the continuous-time functions
CONTINUOUS = {
    "set_time": ("fmi2SetTime", "fmi3SetTime"),
    "set_x": ("fmi2SetContinuousStates", "fmi3SetContinuousStates"),
    "get_dx": ("fmi2GetDerivatives", "fmi3GetContinuousStateDerivatives"),
    "get_z": ("fmi2GetEventIndicators", "fmi3GetEventIndicators"),
}

#: FMI type -> (C getter without the fmi2/fmi3 prefix, numpy dtype of its values)
GETTERS = {
    "Real": ("GetReal", np.float64), "Integer": ("GetInteger", np.int32),
    "Enumeration": ("GetInteger", np.int32), "Boolean": ("GetBoolean", np.int32),  # FMI 2.0
    "Float64": ("GetFloat64", np.float64), "Float32": ("GetFloat32", np.float32),
    "Int8": ("GetInt8", np.int8), "UInt8": ("GetUInt8", np.uint8), "Int16": ("GetInt16", np.int16),
    "UInt16": ("GetUInt16", np.uint16), "Int32": ("GetInt32", np.int32), "UInt32": ("GetUInt32", np.uint32),
    "Int64": ("GetInt64", np.int64), "UInt64": ("GetUInt64", np.uint64),
}
#: FMI 3.0 types whose getter differs from FMI 2.0's of the same name
GETTERS3 = {"Boolean": ("GetBoolean", np.bool_), "Enumeration": ("GetInt64", np.int64)}


def error(name, status):
    """fmpy's ``FMICallException`` for the FMI function ``name`` that returned ``status``."""
    from fmpy.fmi1 import FMICallException

    return FMICallException(function=name, status=status)


class BoundCalls:
    """setTime, setContinuousStates, getDerivatives / getContinuousStateDerivatives,
    getEventIndicators and the output getters of one Model Exchange FMU instance.

    Parameters
    ----------
    fmu : fmpy.fmi2.FMU2Model or fmpy.fmi3.FMU3Model
        An instantiated FMU (its ``dll`` and ``component``).
    fmi3 : bool
        FMI 3.0 (else 2.0).
    nx, nz : int
        Number of continuous states and event indicators.
    out_types : dict
        ``{FMI type: (element positions, value references, number of values)}`` of the
        outputs (:func:`hybridsim.fmi.variables._by_type`).

    ``x``, ``dx`` and ``z`` are the float64 buffers (``nx``, ``nx``, ``nz``) the
    continuous-time calls read and write.
    """

    def __init__(self, fmu, fmi3, nx, nz, out_types):
        prefix = "fmi3" if fmi3 else "fmi2"
        self.x, self.dx, self.z = np.zeros(nx), np.zeros(nx), np.zeros(nz)
        self.nx, self.nz = nx, nz
        self.names = {k: v[fmi3] for k, v in CONTINUOUS.items()}
        for key, name in self.names.items():
            args = [_P, ctypes.c_double] if key == "set_time" else [_P, _P, _N]
            setattr(self, "_" + key, self._bind(fmu, name, args))
        # the arguments as ctypes objects made once (converting Python ints costs more than the call)
        self._c = _P(fmu.component)
        self._ax, self._adx, self._az = ((self._c, _P(a.ctypes.data), _N(a.size)) for a in (self.x, self.dx, self.z))
        self._keep = []  # the value-reference arrays whose addresses the getters hold
        self.getters = []  # (type, C name, function, its arguments, values, positions)
        for typ, (positions, vrs, n) in out_types.items():
            suffix, dtype = (GETTERS3.get(typ) if fmi3 else None) or GETTERS[typ]
            name = prefix + suffix
            fn = self._bind(fmu, name, [_P, _P, _N, _P, _N] if fmi3 else [_P, _P, _N, _P])
            vr = np.array(vrs, dtype=np.uint32)
            values = np.zeros(n, dtype=dtype)
            args = (self._c, _P(vr.ctypes.data), _N(len(vr)), _P(values.ctypes.data)) + ((_N(n),) if fmi3 else ())
            self._keep.append(vr)
            first = positions[0]  # a slice when the positions are contiguous (the usual case)
            contiguous = list(positions) == list(range(first, first + n))
            where = slice(first, first + n) if contiguous else np.array(positions, dtype=np.intp)
            self.getters.append((typ, name, fn, args, values, where))

    @staticmethod
    def _bind(fmu, name, argtypes):
        fn = fmu.dll[name]  # a new function object: fmpy's own keeps the signature it gave
        fn.restype, fn.argtypes = ctypes.c_int, argtypes
        return fn

    def set_state(self, t, x):
        """setTime(t) [s], then setContinuousStates(x) when there are states.

        Returns None, or ``(C function, status)`` of the call that failed.
        """
        status = self._set_time(self._c, t)
        if status > 1:
            return self.names["set_time"], status
        if self.nx:
            self.x[:] = x
            status = self._set_x(*self._ax)
            if status > 1:
                return self.names["set_x"], status
        return None

    def get_dx(self):
        """The state derivatives into ``self.dx``; returns the FMI status."""
        return self._get_dx(*self._adx)

    def get_z(self):
        """The event indicators into ``self.z``; returns the FMI status."""
        return self._get_z(*self._az)

    def failure(self, key, status):
        """fmpy's ``FMICallException`` for the call ``key`` (``"get_dx"``, ...) that returned ``status``."""
        return error(self.names.get(key, key), status)

    def outputs(self, out, fail):
        """Every output into the float array ``out`` (at its element positions).

        ``fail(type, exception)`` is called for a failed getter (it raises).
        """
        for typ, name, fn, args, values, positions in self.getters:
            status = fn(*args)
            if status > 1:
                fail(typ, error(name, status))
            out[positions] = values
        return out
