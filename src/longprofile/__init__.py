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

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("longprofile")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "0.0.0"

__all__ = ["__version__"]
