"""Checks of a noise std the user gives instead of letting the data estimate it (``sigma``; CLI ``--sigma-deg``).

Paper 004 §4.2 takes the std of the angle measurements as known (sigma = 5e-3 deg, "estimated from the sensors'
data" — the noise of single readings). The estimator works on daily medians of about a hundred readings, whose
changes are about 6 times quieter: the robust day-to-day std of the daily slope changes
(:func:`~longprofile.rail._settle.day_difference_sigma`) is 7.6e-4 to 8.2e-4 deg on the simulated presets
(mittersheim-like and farebersviller-like, seeds 0-2; docs/rail.md, "A user's probe"). A datasheet's
"±0.05°" is the sensor's absolute accuracy, not this noise: given as ``sigma`` it is 60 times too large, the health
tests then see the bowl's sensors as improbable and the settlement printed is 0.0 mm with a tight band (a user's
probe, session 39). Hence two checks:

* :func:`check_sigma_range`: a value outside :data:`SIGMA_RANGE_DEG` is refused whatever the data;
* :func:`compare_with_estimate`: where the record allows an estimate of the data's noise (the estimator passes
  the sensors' scatter about their neighbours, :func:`~longprofile.rail._settle.day_noise_variances`), a value more than
  :data:`SIGMA_REFUSE_FACTOR` from it is refused and one more than :data:`SIGMA_WARN_FACTOR` from it gets a warning
  (calibrated on mittersheim-like seeds 0 and 1 and a 3-day cut: the 90 % band covered 47-64 % at a third of the
  estimate, 71-74 % at half, 92-95 % at the estimate, 99.7-100 % at twice it; farebersviller-like seed 0: 96-98 %
  below the estimate, 99.4 % at twice it; docs/rail.md, "A user's probe").
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["SIGMA_RANGE_DEG", "SIGMA_WARN_FACTOR", "SIGMA_REFUSE_FACTOR", "check_sigma_range",
           "compare_with_estimate"]

#: The plausible range of the std of a daily-median angle change, deg: about 80 times below the presets' (room for
#: sensors far quieter than the simulated ones) to twice the paper's single-reading noise (a daily median is never
#: noisier than one reading).
SIGMA_RANGE_DEG = (1e-5, 1e-2)
#: A given sigma this many times above or below the data's own noise gets a warning (module docstring).
SIGMA_WARN_FACTOR = 2.0
#: ... and this many times is refused.
SIGMA_REFUSE_FACTOR = 10.0
#: What the messages say a daily-median change's noise looks like.
_TYPICAL = ("on the simulated presets it is about 8e-4 deg (the paper's 5e-3 deg is the noise of one reading, a "
            "datasheet's ±0.05° the sensor's absolute accuracy: neither is this noise)")


def _show(sigma: float) -> str:
    return f"sigma = {sigma:.3g} rad ({np.rad2deg(sigma):.3g} deg; CLI --sigma-deg)"


def check_sigma_range(sigma) -> float:
    """``sigma`` (rad) as a float if it is a plausible std of a daily-median angle change (:data:`SIGMA_RANGE_DEG`),
    else :class:`~longprofile.errors.InputError` saying what is plausible and that it can be left out."""
    try:
        s = float(sigma)
    except (TypeError, ValueError):
        raise InputError(f"sigma must be a number of radians; got {sigma!r}.") from None
    lo, hi = np.deg2rad(SIGMA_RANGE_DEG)
    if not np.isfinite(s) or not lo <= s <= hi:
        raise InputError(f"{_show(s)} is not a plausible std of the day-to-day change of a daily-median angle: it "
                         f"lies between {SIGMA_RANGE_DEG[0]:g} and {SIGMA_RANGE_DEG[1]:g} deg; {_TYPICAL}. Leave it "
                         "out to estimate it from the data.")
    return s


def compare_with_estimate(sigma: float, estimate: float, *, source: str = "the day-to-day differences") -> str:
    """A given ``sigma`` against the data's ``estimate`` (rad): "" when within :data:`SIGMA_WARN_FACTOR`, a warning
    beyond it, :class:`~longprofile.errors.InputError` beyond :data:`SIGMA_REFUSE_FACTOR`."""
    ratio = float(sigma) / float(estimate)
    if 1.0 / SIGMA_WARN_FACTOR <= ratio <= SIGMA_WARN_FACTOR:
        return ""
    what = (f"{_show(sigma)} is {ratio:.3g} times the noise the data show ({np.rad2deg(estimate):.2g} deg, from "
            f"{source})")
    refuse = ratio > SIGMA_REFUSE_FACTOR or ratio < 1.0 / SIGMA_REFUSE_FACTOR
    if ratio < 1:
        effect = ("the bands are too narrow (on mittersheim-like the 90 % band covered 71-74 % of the truth at half the "
                  "data's value, 47-64 % at a third) and healthy sensors are excluded")
    elif refuse:
        effect = ("the health tests and the settlement's prior take real movements for noise (at 60 times, a "
                  "mittersheim-like bowl's sensors were all excluded and 0.0 mm printed with a tight band)")
    else:
        effect = ("the bands are too wide (on the presets the 90 % band covered 99.4-100 % of the truth at twice the "
                  "data's value) and movements are smoothed (at 10 times the RMS error doubled)")
    if refuse:
        raise InputError(f"{what}: {effect}. Leave it out to estimate it (or give a value within a factor "
                         f"{SIGMA_WARN_FACTOR:g} of the data's).")
    return f"{what}: {effect}. Leaving it out estimates it from the data."
