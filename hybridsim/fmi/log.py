"""One FMI 2.0 logger for the whole process, shared safely with fmpy.

FMI 2.0 loggers are variadic (``printf`` style); Python callbacks cannot read
the extra arguments, so fmpy formats them in a native proxy
(``fmpy.logging.addLoggerProxy``). That proxy keeps a single global pointer to
the Python logger it forwards to: whoever registers last receives every FMU's
messages, and once that callback is freed the next message crashes the process
(a segmentation fault seen in CI). So hybridsim registers one logger, once,
that lives as long as the process. It hands a message to the FMU block whose
``componentEnvironment`` key the FMU passes back, and any other message (an
FMU that fmpy itself instantiated) to fmpy's own printer, as before.
"""
import ctypes
import itertools
import threading

_SINKS = {}  # componentEnvironment key -> list of messages of one live FMU block
_KEYS = itertools.count(1)
_LOCK = threading.Lock()
_LOGGER = []  # [the ctypes callback, the formatting proxy in front of it], set once


def _forward(env, name, status, category, message):
    sink = _SINKS.get(env)
    if sink is not None:
        sink.append(message.decode(errors="replace") if message else "")
        return
    from fmpy.fmi2 import printLogMessage

    printLogMessage(env, name, status, category, message or b"")


def logger():
    """The logger to put in ``fmi2CallbackFunctions.logger``.

    Returns
    -------
    ctypes function pointer
        fmpy's formatting proxy when it is available (messages arrive
        formatted), else hybridsim's logger itself (format strings unformatted).
    """
    with _LOCK:
        if not _LOGGER:
            from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

            own = fmi2CallbackLoggerTYPE(_forward)
            holder = fmi2CallbackFunctions()
            holder.logger = own
            try:
                from fmpy.logging import addLoggerProxy

                addLoggerProxy(ctypes.byref(holder))  # the proxy now forwards to `own`, for good
            except Exception:  # noqa: BLE001 - no native proxy on this platform: unformatted messages
                pass
            _LOGGER.extend([own, holder.logger])
        return _LOGGER[1]


def open_sink(messages):
    """Route messages to ``messages`` (a list); returns the key for ``componentEnvironment``.

    Parameters
    ----------
    messages : list of str
        Where this FMU instance's messages are appended.

    Returns
    -------
    int
        The key, to pass to :func:`close_sink` when the instance is freed.
    """
    key = next(_KEYS)
    _SINKS[key] = messages
    return key


def close_sink(key):
    """Stop routing messages for ``key`` (later ones go to fmpy's printer).

    Parameters
    ----------
    key : int or None
        A key from :func:`open_sink`; None does nothing.
    """
    if key is not None:
        _SINKS.pop(key, None)
