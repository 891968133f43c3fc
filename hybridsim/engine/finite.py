"""One check the run makes at every step and right-hand side: are these numbers all finite?"""
import math

import numpy as np


def all_finite(a):
    """True when every element of the float array ``a`` is finite.

    Small arrays (a right-hand side's derivatives, a wire vector) are summed as Python floats:
    any NaN or infinity makes the sum non-finite, and a sum that overflows is checked again
    element by element. That is about a tenth of ``np.isfinite(a).all()`` on a few elements.
    """
    if a.size <= 256:
        return math.isfinite(sum(a.tolist())) or bool(np.isfinite(a).all())
    return bool(np.isfinite(a).all())
