"""longprofile — recover road and rail longitudinal profiles, road grade and
vehicle states from indirect sensors, with one state-space engine.

Subpackages
-----------
statespace -- Kalman filter, RTS smoother, EKF, steady-state filters, observers, likelihood.
signal     -- derivative estimators of noisy sampled signals (paper 002).
identify   -- system identification (output-error, ARMAX) and maximum likelihood.
road       -- APL trailer model and profile reconstruction, roughness indices (paper 000).
rail       -- track settlement from sleeper inclinometers (paper 004).
vehicle    -- vehicle state and road slope estimation (paper 001, thesis 003).
io         -- profile and signal files (CSV, Parquet, ERD).
report     -- plots and HTML reports.
errors     -- the exception hierarchy.
"""

__all__ = ["__version__"]


def __getattr__(name: str):
    """``__version__`` from the installed distribution, read on first use (importlib.metadata costs 0.1-0.2 s of
    start-up, which most commands do not need)."""
    if name != "__version__":
        raise AttributeError(f"module 'longprofile' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("longprofile")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
        value = "0.0.0"
    globals()["__version__"] = value
    return value
