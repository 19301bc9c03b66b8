"""Rail track settlement from sleeper inclinometers, with confidence bands (paper 004).

Data
----
SiteData                    -- validated site: sensors, readings, survey, controls, warnings.
validate_site               -- validate the four long-format tables (clear errors, explicit warnings).
read_site                   -- read them from CSV / Parquet and validate.
simulate_site               -- synthetic site with ground truth ("mittersheim-like", "farebersviller-like").
SyntheticSite, SiteTruth    -- its tables and truth.

The paper's methods
-------------------
integrate_angles            -- forward / backward / average / convex chain integration (§2).
bar_angles_from_profile     -- initial bar angles from altitudes (§2).
daily_angles, DailyAngles   -- outlier removal, linear (§3) or lagged thermal correction, daily medians.
first_order_response        -- first-order thermal lag of a temperature series.
rigidity_cost_matrix        -- the cost matrix C of Lemma 4.1 (§4.2).
rigidity_posterior_dense    -- the paper's dense posterior (reference, O(N^3)).
rigidity_model              -- the same prior as a state-space model (integrated Wiener process);
                               penalty_order=3 gives the smoother ||f'''||^2 prior (beyond the paper).
rigidity_posterior          -- O(N) posterior by RTS smoothing over the stations, batched over days.
ProfilePosterior            -- posterior means, stds, station and cross covariances.
measurement_std             -- std of the posterior mean due to the slope noise alone (a lower bound).
initial_profile_posterior   -- initial altitudes and angles from a survey on any grid (§4.4), O(N).
initial_profile_posterior_dense -- §4.4 dense reference (survey at the sensors).
sample_profiles             -- posterior draws of altitude profiles.
max_settlement_monte_carlo  -- mean and std of the maximum settlement (§4.3).
affine_correction           -- the affine correction of §5.2 (with the paper's warning).
assess_sensors, SensorHealth -- flag dead / reversed / drifting / detached / improbable sensors (§6).

Beyond the paper
----------------
smooth_through_time         -- settlement smoothed across days per station, daily rates with bands;
                               TemporalSettlement is its result.
settlement_alarms           -- threshold exceedances with station, date and probability.
fit_change_prior            -- maximum-likelihood prior (order and r) of the settlement profile;
                               ChangePriorFit is its result.
estimate_settlement         -- the whole job, readings to settlement, bands, health and alarms.
SettlementResult            -- its result (``to_table()`` for the long output table).
"""

from ._data import SiteData, read_site, validate_site
from ._health import SensorHealth, assess_sensors
from ._integration import bar_angles_from_profile, integrate_angles
from ._rigidity import (ProfilePosterior, initial_profile_posterior, initial_profile_posterior_dense,
                        max_settlement_monte_carlo, measurement_std, rigidity_cost_matrix, rigidity_model,
                        rigidity_posterior, rigidity_posterior_dense, sample_profiles)
from ._settle import ChangePriorFit, SettlementResult, affine_correction, estimate_settlement, fit_change_prior
from ._synthetic import SiteTruth, SyntheticSite, simulate_site
from ._temporal import TemporalSettlement, settlement_alarms, smooth_through_time
from ._thermal import DailyAngles, daily_angles, first_order_response

__all__ = [
    "SiteData", "read_site", "validate_site", "simulate_site", "SyntheticSite", "SiteTruth",
    "integrate_angles", "bar_angles_from_profile", "daily_angles", "DailyAngles", "first_order_response",
    "rigidity_cost_matrix", "rigidity_posterior_dense", "rigidity_model", "rigidity_posterior", "ProfilePosterior",
    "measurement_std", "initial_profile_posterior", "initial_profile_posterior_dense", "sample_profiles",
    "max_settlement_monte_carlo", "affine_correction", "assess_sensors", "SensorHealth",
    "smooth_through_time", "TemporalSettlement", "settlement_alarms", "estimate_settlement", "SettlementResult",
    "fit_change_prior", "ChangePriorFit",
]
