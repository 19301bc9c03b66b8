"""``derivative_std``: the total-error std (default) against the noise-only one (issue 13, docs/signal.md Calibration)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.signal import derivative, derivative_kalman, kalman_differentiator_model, variance_gain
from longprofile.signal import polyfit_coefficients as _polyfit_taps
from longprofile.statespace import kalman_filter, rts_smoother
from tests._fingerprint import assert_same_fingerprint, fingerprint

DT = 1e-3
Z90 = 1.6448536269514722


def _band_limited(seed, n=6000, cutoff=5.0, noise=1e-3):
    """Band-limited random signal (30 sines up to ``cutoff`` Hz), its derivative, and noisy samples."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    f = rng.uniform(0.0, cutoff, 30)
    a, ph = rng.standard_normal(30) / np.sqrt(30), rng.uniform(0, 2 * np.pi, 30)
    arg = 2 * np.pi * f[:, None] * t + ph[:, None]
    clean = (a[:, None] * np.sin(arg)).sum(0)
    truth = (a[:, None] * 2 * np.pi * f[:, None] * np.cos(arg)).sum(0)
    sigma = noise * np.std(clean)
    return clean + sigma * rng.standard_normal(n), truth, sigma


def _coverage(res, truth, skip=1500):
    err, std = (res.derivative - truth)[skip:], res.derivative_std[skip:]
    return float(np.mean(np.abs(err) <= Z90 * std))


# --------------------------------------------------------------------------- the noise-only option is today's std
def _digest_cases():
    rng = np.random.default_rng(20261206)
    t = np.arange(3000) * DT
    x = np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 4.1 * t + 1) + 0.01 * rng.standard_normal(t.size)
    xn = x.copy()
    xn[[700, 701, 1900]] = np.nan
    x2 = np.column_stack([x, 2 * x + 0.02 * rng.standard_normal(t.size)])
    return {"ml45": (x, dict(method="ml", window=45, degree=2)),
            "ml-nan": (xn, dict(method="ml", window=30, degree=3, noise_std=0.01)),
            "ml-fir": (x, dict(method="ml", window=12, degree=1, implementation="fir", noise_std=0.01)),
            "polyfit": (x2, dict(method="polyfit", window=20, degree=1, noise_std=[0.01, 0.03])),
            "polyfit-o2": (x, dict(method="polyfit", window=60, degree=2, order=2)),
            "backward": (x, dict(method="backward", degree=2)),
            "kalman": (xn, dict(method="kalman", q_over_r=1e9, noise_std=0.01)),
            "kalman-smooth": (x2, dict(method="kalman", q_over_r=1e8, smooth=True)),
            "kalman-ss": (x, dict(method="kalman", q_over_r=1e10, steady_state=True, order=2, noise_std=0.01))}


#: Fingerprints (tests/_fingerprint.py: shape, NaN mask, weighted sums) of value, derivative, derivative_std computed
#: by the code before issue 13 (commit 1f45edc, which had only the noise-only std) on :func:`_digest_cases`; equal
#: to 1e-9 of each array's scale (a sha256 would fail on the last bits a compiling process, e.g. a fresh clone, moves).
BEFORE_ISSUE_13 = {
    "ml45": {
        "derivative": ([3000], "7c6e62a351f6f944", [-1005.0869734725298, -1419.5183777412617, -1450.1059428559934],
                   28342.452132451268),
        "derivative_std": ([3000], "7c6e62a351f6f944", [2736.304290831923, 2734.2004898269643, 2748.558131139105],
                   2747.9476804146716),
        "value": ([3000], "7c6e62a351f6f944", [30.008671439129927, 22.91007227432297, 26.573533112184492],
                   1899.7181762413427),
    },
    "ml-nan": {
        "derivative": ([3000], "8827ad80080a79e0", [-1668.2531145438948, -2013.2461790817192, -2074.935687050409],
                   26429.80580454162),
        "derivative_std": ([3000], "8827ad80080a79e0", [7702.27908631837, 7704.046046998599, 7740.943193255718],
                   7734.91216452331),
        "value": ([3000], "8827ad80080a79e0", [45.17538954491803, 36.00966616557881, 39.65883288102134],
                   1902.209722194254),
    },
    "ml-fir": {
        "derivative": ([3000], "57b4eb86e8e65574", [-689.9904302472106, -1082.9980442551177, -1100.4003597331894],
                   26762.1844851547),
        "derivative_std": ([3000], "57b4eb86e8e65574", [3757.0718589741064, 3754.831803621427, 3771.788490517928],
                   3772.2788835642323),
        "value": ([3000], "57b4eb86e8e65574", [53.84247480190592, 46.92420653565355, 49.097696393150585],
                   1923.1018624654635),
    },
    "polyfit": {
        "derivative": ([3000, 2], "5b6ce62a887c8435", [-2776.9595242143705, -2749.3597279409914, -3333.8850667480756],
                   79509.58361557893),
        "derivative_std": ([3000, 2], "5b6ce62a887c8435", [4274.406098786056, 4280.032621531819, 4303.4102591175015],
                   4295.669822132426),
        "value": ([3000, 2], "5b6ce62a887c8435", [146.57873152837897, 98.33129089378815, 114.55893031723349],
                   5778.170252435671),
    },
    "polyfit-o2": {
        "derivative": ([3000], "3277a4db450db99a", [-5607.900285271993, -7658.522066070223, -13407.24633170413],
                   600483.0851612701),
        "derivative_std": ([3000], "3277a4db450db99a", [27742.008432331564, 27687.818394304653, 27848.886237406365],
                   27834.944812919937),
        "value": ([3000], "3277a4db450db99a", [20.498617590351586, 10.419859491438842, 15.26975937723023],
                   1890.7574534326363),
    },
    "backward": {
        "derivative": ([3000], "8a171b599163dce2", [-968.1444233831006, -772.4891368487259, -1064.9480914467351],
                   65813.36011061865),
        "derivative_std": ([3000], "8a171b599163dce2", [78030.58114156825, 77948.92704112316, 78308.9084363206],
                   78324.52337870296),
        "value": ([3000], "8a171b599163dce2", [59.32406220369714, 51.679811458439076, 54.048666838004095],
                   1928.1714689582855),
    },
    "kalman": {
        "derivative": ([3000], "23790b6edf979903", [-613.4976491732077, -1197.658511576225, -958.6078416827164],
                   42004.11815170903),
        "derivative_std": ([3000], "23790b6edf979903", [11351.521750170692, 22003.228272989505, 17430.42317461768],
                   14890.624988747708),
        "value": ([3000], "23790b6edf979903", [59.57318053690611, 50.77163521949936, 57.95266378670925],
                   2061.169746377296),
    },
    "kalman-smooth": {
        "derivative": ([3000, 2], "d75ca3270d5d00ed", [-2007.9649938648727, -2139.7065905638237, -2610.3874407702456],
                   51567.16679645183),
        "derivative_std": ([3000, 2], "d75ca3270d5d00ed", [161.77870858554755, 162.35546942240495, 162.75794076280607],
                   162.64786385203982),
        "value": ([3000, 2], "d75ca3270d5d00ed", [170.77692026870386, 123.04022096263782, 145.70821834506637],
                   5679.303293343074),
    },
    "kalman-ss": {
        "derivative": ([3000], "23790b6edf979903", [4541.812119961109, 758.5805492781255, -5005.0409821525445],
                   619932.6976346213),
        "derivative_std": ([3000], "23790b6edf979903", [19503.079951308537, 19492.053014006626, 19576.823099171044],
                   19579.48581673878),
        "value": ([3000], "23790b6edf979903", [62.818031646103776, 54.910246843729794, 57.76016396968453],
                   1962.5634807963438),
    },
}


@pytest.mark.parametrize("name", sorted(_digest_cases()))
def test_noise_option_is_the_std_before_issue_13(name):
    x, kwargs = _digest_cases()[name]
    res = derivative(x, DT, std="noise", **kwargs)
    got = fingerprint(dict(value=res.value, derivative=res.derivative, derivative_std=res.derivative_std))
    assert_same_fingerprint(got, BEFORE_ISSUE_13[name])


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), method=st.sampled_from(["ml", "polyfit", "backward"]),
       degree=st.integers(1, 3), window=st.integers(3, 80), order=st.integers(1, 2), given_noise=st.booleans())
def test_fir_total_std_keeps_the_estimates_and_is_at_least_the_noise_std(seed, method, degree, window, order,
                                                                        given_noise):
    order = min(order, degree)
    x, _, sigma = _band_limited(seed, n=600, cutoff=20.0, noise=1e-2)
    kwargs = dict(method=method, degree=degree, order=order, noise_std=sigma if given_noise else None)
    if method != "backward":
        kwargs["window"] = max(window, degree)
    total, noise = derivative(x, DT, **kwargs), derivative(x, DT, std="noise", **kwargs)
    np.testing.assert_array_equal(total.derivative, noise.derivative)
    np.testing.assert_array_equal(total.value, noise.value)
    np.testing.assert_array_equal(np.isnan(total.derivative_std), np.isnan(noise.derivative))
    ok = np.isfinite(noise.derivative_std)
    assert np.all(total.derivative_std[ok] >= noise.derivative_std[ok])
    assert total.params["std"] == "total" and noise.params["std"] == "noise"


def test_fir_noise_std_is_the_tap_formula():
    x, _, _ = _band_limited(3, n=400)
    res = derivative(x, DT, method="polyfit", window=25, degree=2, noise_std=0.01, std="noise")
    expected = 0.01 * np.sqrt(float(variance_gain(_polyfit_taps(25, 2)))) / DT
    np.testing.assert_array_equal(res.derivative_std[25:], expected)


@pytest.mark.parametrize("smooth", [False, True])
def test_kalman_noise_std_is_the_posterior_std(smooth):
    x, _, sigma = _band_limited(4, n=800)
    res = derivative_kalman(x, DT, q_over_r=1e9, noise_std=sigma, smooth=smooth, std="noise")
    model = kalman_differentiator_model(DT, q_over_r=1e9, noise_std=sigma)
    post = kalman_filter(model, (x - x[0])[:, None])
    post = rts_smoother(model, post) if smooth else post
    np.testing.assert_array_equal(res.derivative_std, np.sqrt(np.maximum(post.cov[:, 1, 1], 0.0)))


# --------------------------------------------------------------------------- coverage where the bias dominates
#: (method options, window or q/r far from the error-optimal one for a 5 Hz band at 1e-3 noise: bias dominates)
BIASED = [dict(method="ml", degree=2, window=180), dict(method="polyfit", degree=1, window=90),
          dict(method="ml", degree=1, window=60), dict(method="polyfit", degree=2, window=250),
          dict(method="kalman", q_over_r=1e8), dict(method="kalman", q_over_r=6e7, smooth=True)]


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 100_000), case=st.sampled_from(range(len(BIASED))))
def test_total_std_covers_where_the_bias_dominates(seed, case):
    # four random signals pooled (one signal's coverage scatters: its bias varies slowly)
    cover = {"noise": [], "total": []}
    for k in range(4):
        x, truth, sigma = _band_limited(seed + k)
        for std in cover:
            cover[std].append(_coverage(derivative(x, DT, std=std, noise_std=sigma, **BIASED[case]), truth))
    assert np.mean(cover["noise"]) < 0.7  # the noise-only std misses the bias
    assert 0.8 <= np.mean(cover["total"]) <= 0.98


@pytest.mark.parametrize("kwargs", [dict(method="polyfit", degree=2, window=40),
                                    dict(method="kalman", q_over_r=1e10)])
def test_total_std_covers_pure_noise(kwargs):
    # no signal: no bias; the total std must not blow up the noise-only interval
    x = np.random.default_rng(9).normal(0.0, 0.1, 40_000)
    res = derivative(x, DT, noise_std=0.1, **kwargs)
    assert 0.88 <= _coverage(res, np.zeros_like(x), skip=2000) <= 0.97


def test_std_option_is_validated():
    with pytest.raises(InputError, match="std must be one of"):
        derivative(np.arange(50.0), 0.1, method="ml", window=5, std="bias")
    with pytest.raises(InputError, match="std must be one of"):
        derivative_kalman(np.arange(50.0), 0.1, q_over_r=1.0, std=None)


@settings(max_examples=40, deadline=None)
@given(n_steps=st.integers(1, 1500), width=st.integers(1, 80), centred=st.booleans(),
       nan_share=st.sampled_from([0.0, 0.3]), seed=st.integers(0, 1000))
def test_moving_mean_square_is_that_of_the_finite_values_in_the_window(n_steps, width, centred, nan_share, seed):
    # records up to 1500 samples: past several exact recomputes of the running sum (every 16 window lengths)
    from longprofile.signal._total_std import _moving_mean_square

    rng = np.random.default_rng(seed)
    v = rng.random((2, n_steps)) - 0.5
    v[rng.random(v.shape) < nan_share] = np.nan
    got = _moving_mean_square(v, width, centred)
    lo_off, hi_off = (width // 2, width - width // 2) if centred else (width - 1, 1)
    for b in range(2):
        for k in range(n_steps):
            window = v[b, max(k - lo_off, 0):min(k + hi_off, n_steps)]
            finite = window[np.isfinite(window)]
            if finite.size:
                assert abs(got[b, k] - np.mean(finite ** 2)) <= 1e-12
            else:
                assert np.isnan(got[b, k])
