"""Closed-loop linear models a linearization returns: sampled (z-plane) or continuous (s-plane).

Both answer the same questions - poles, how many sit at the integrator point
(z = 1 or s = 0), the growth of the rest, whether it is asymptotically
stable, a pole table - so the analysis and the report read either alike.
"""
import numpy as np


class DiscreteModel:
    """A closed-loop discrete system s+ = M s over period ``period`` (s)."""

    domain = "discrete"
    growth_label = "largest |z|"

    def __init__(self, M, period, names, fd_error=0.0):
        self.M, self.period, self.names, self.fd_error = M, period, names, fd_error

    @property
    def poles(self):
        return np.linalg.eigvals(self.M)

    @property
    def spectral_radius(self):
        return float(np.max(np.abs(self.poles))) if self.M.size else 0.0

    @property
    def integrator_modes(self):
        """Number of poles at z = 1 (to 1e-7): integrator directions that no
        signal drives (e.g. a joint-space integrator fed through a selection
        matrix). They stay constant: bounded, neither decaying nor growing."""
        return int(np.sum(np.abs(self.poles - 1.0) < 1e-7))

    @property
    def growth(self):
        """Largest ``|z|`` apart from the poles at z = 1; < 1 means asymptotically
        stable except for constant integrator directions."""
        p = self.poles
        rest = p[np.abs(p - 1.0) >= 1e-7]
        return float(np.max(np.abs(rest))) if rest.size else 0.0

    @property
    def stable(self):
        return self.growth < 1.0 - 1e-9

    def pole_table(self):
        """Rows (z, ``|z|``, frequency Hz, damping) with s = ln(z)/T; sorted by ``|z|`` descending."""
        rows = []
        for z in self.poles:
            if abs(z) < 1e-12:
                rows.append({"z": z, "pole": z, "abs": 0.0, "freq_hz": None, "damping": None})
                continue
            if abs(z - 1.0) < 1e-7:  # an integrator direction (see integrator_modes): s = 0, no damping ratio
                rows.append({"z": z, "pole": z, "abs": float(abs(z)), "freq_hz": 0.0, "damping": None})
                continue
            s = np.log(complex(z)) / self.period
            wn = abs(s)
            rows.append({"z": z, "pole": z, "abs": float(abs(z)), "freq_hz": float(wn / (2 * np.pi)),
                         "damping": float(-s.real / wn) if wn > 0 else 1.0})
        return sorted(rows, key=lambda r: -r["abs"])


class ContinuousModel:
    """A closed-loop continuous system x' = A x (a diagram with nothing sampled).

    ``growth`` is the largest real part of the poles (1/s) apart from those at
    s = 0; < 0 means asymptotically stable except for constant directions
    (a free mass's position, an integrator no signal drives).
    """

    domain = "continuous"
    growth_label = "largest Re s (1/s)"
    period = None

    def __init__(self, A, names, fd_error=0.0):
        self.A, self.names, self.fd_error = A, names, fd_error

    @property
    def poles(self):
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, complex)

    def _zero_tol(self):
        """Poles within this of s = 0 count as at s = 0 (the finite differences' resolution)."""
        p = self.poles
        return 1e-7 * max(1.0, float(np.max(np.abs(p)))) if p.size else 0.0

    @property
    def spectral_abscissa(self):
        """Largest real part of all poles (1/s)."""
        p = self.poles
        return float(np.max(p.real)) if p.size else -np.inf

    @property
    def integrator_modes(self):
        """Number of poles at s = 0 (relative to the largest pole, 1e-7)."""
        return int(np.sum(np.abs(self.poles) <= self._zero_tol()))

    @property
    def growth(self):
        """Largest Re s apart from the poles at s = 0 (1/s); 0 when every pole is there."""
        p = self.poles
        rest = p[np.abs(p) > self._zero_tol()]
        return float(np.max(rest.real)) if rest.size else 0.0

    @property
    def stable(self):
        """Every pole but those at s = 0 strictly in the left half plane (an undamped mode is not),
        and those at s = 0 constant directions: as many independent null vectors of A as poles
        there (a double integrator, e.g. a body in free fall, drifts and is not stable)."""
        p = self.poles
        rest = p[np.abs(p) > self._zero_tol()]
        if not np.all(rest.real < -self._zero_tol()):
            return False
        sv = np.linalg.svd(self.A, compute_uv=False) if self.A.size else np.zeros(0)
        null = int(np.sum(sv <= 1e-9 * sv.max())) if sv.size and sv.max() > 0 else sv.size
        return null >= self.integrator_modes

    def pole_table(self):
        """Rows (s, ``|s|`` rad/s, natural frequency Hz, damping); sorted by Re s descending."""
        rows = []
        for s in self.poles:
            wn = abs(s)
            rows.append({"s": s, "pole": s, "abs": float(wn), "freq_hz": float(wn / (2 * np.pi)) if wn else None,
                         "damping": float(-s.real / wn) if wn > 0 else None})
        return sorted(rows, key=lambda r: -r["pole"].real)


def oscillatory_modes(A):
    """Oscillatory eigenfrequencies (Hz, to 1e-6) of a continuous A, highest first.

    Parameters
    ----------
    A : (n, n) array
        x' = A x.

    Returns
    -------
    list of float
        ``|Im s| / 2 pi`` of each eigenvalue with ``Im s > 0``, without repeats.
    """
    ev = np.linalg.eigvals(A)
    return sorted({round(abs(e.imag) / (2 * np.pi), 6) for e in ev if e.imag > 0}, reverse=True)
