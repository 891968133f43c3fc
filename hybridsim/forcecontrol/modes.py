"""The hand mode: the plant's oscillatory mode nearest ``analysis: hand_mode_hz``.

The paper's hand rings on the wrist sensor's stiffness (eq 18, ~272 Hz); ``hybridsim
analyze`` reports the linearized plant's mode nearest the frequency the diagram
names. Registered with :func:`hybridsim.analysis.extras.register`.
"""
from hybridsim.analysis import extras
from hybridsim.analysis.lti import oscillatory_modes


def hand_modes(A, near_hz=None):
    """Oscillatory eigenfrequencies (Hz) of a continuous ``A``, highest first; with ``near_hz``
    the one nearest it (None when there is none).

    Parameters
    ----------
    A : (n, n) array
        The linearized plant, x' = A x (+ B h).
    near_hz : float, optional
        A frequency (Hz).
    """
    f = oscillatory_modes(A)
    if near_hz is not None:
        return min(f, key=lambda x: abs(x - near_hz)) if f else None
    return f


def _nearest(settings, A):
    hz = settings.get("hand_mode_hz")
    return None if not hz else hand_modes(A, float(hz))


extras.register("hand_mode_hz", _nearest, lambda hz: f"plant mode nearest eq 18: {hz:.2f} Hz")
