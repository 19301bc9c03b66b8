"""Road profiles: the APL trailer model and reconstruction (paper 000), roughness indices and spectra.

Profile -- a longitudinal profile (stations in m, elevations in m, one column per track).
"""

from ._profile import Profile

__all__ = ["Profile"]
