"""The one exception type for bad input, and the checks that raise it."""

import numpy as np


class TrackdynInputError(ValueError):
    """Input that trackdyn refuses.

    The message is one line and names the file, row or parameter at fault. The CLI prints
    it without a traceback and exits with code 2.
    """


def require_positive(name: str, value) -> np.ndarray:
    """Return ``value`` as a float array after checking it is finite and > 0.

    Parameters
    ----------
    name : str
        Parameter name used in the error message.
    value : float or array_like
        Value to check.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TrackdynInputError(f"{name} must be a number, got {value!r}") from None
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise TrackdynInputError(f"{name} must be finite and > 0, got {value!r}")
    return arr
