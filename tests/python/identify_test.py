"""Contact-law identification from Python (python/identify.cpp): the paper's Hertz law fitted to
forces made here from known areas, against the closed-form least-squares answer.

Hertz (plugins/hertz/hertz.c): F = 2/(3R) K a^3 with a = sqrt(S/pi), K = E/(1-nu^2). With R held
at 0.037 m and nu at its assumed 0.45, F = K c_i with c_i = 2/(3R) (S_i/pi)^1.5 is linear in K, so
the least-squares K is sum(c F) / sum(c^2), and the asymptotic 95 % interval is
K +- z sqrt(s^2 / sum(c^2)) with s^2 = SSE / (n - 1) (the engine's Gauss-Newton covariance; its
serial-correlation inflation is 1 here because the noise alternates in sign, a negative lag-1
correlation, which the engine clamps to 0)."""

import math

import numpy as np
import pytest

import kneesim

R, NU, K_TRUE = 0.037, 0.45, 6e7
Z95 = 1.959963984540054


def make_trial(name, n, phase, seed):
    rng = np.random.default_rng(seed)
    time = np.arange(n) / 100.0
    S = 2.5e-4 + 1.5e-4 * np.sin(2 * math.pi * time / (n / 100.0) + phase)  # m^2
    c = 2 / (3 * R) * (S / math.pi) ** 1.5
    noise = (-1) ** np.arange(n) * 30 * rng.uniform(0.5, 1.5, n)  # N, alternating in sign
    return {"name": name, "time": time, "channels": {"S": S}, "measured_force": K_TRUE * c + noise}, c


def test_hertz_fit_matches_the_closed_form_least_squares():
    a, ca = make_trial("walk", 200, 0.0, 1)
    b, cb = make_trial("stairs", 150, 1.0, 2)
    r = kneesim.fit_contact_law([a, b], law="hertz", free_parameters=["E", "nu"], assumed_values={"nu": NU},
                                bootstrap_samples=40)
    assert r.success and r.law == "hertz" and r.trials == ["walk", "stairs"]
    c = np.concatenate([ca, cb])
    F = np.concatenate([a["measured_force"], b["measured_force"]])
    K = c @ F / (c @ c)
    sse = np.sum((F - K * c) ** 2)
    se = math.sqrt(sse / (len(F) - 1) / (c @ c))
    assert r.derived["K"]["value"] == pytest.approx(K, rel=1e-7)
    assert r.derived["K_over_R"]["value"] == pytest.approx(K / R, rel=1e-7)
    assert r.derived["K"]["identified"]
    E = r.parameters["E"]
    assert E["status"] == "identified" and E["unit"] == "Pa"
    assert E["value"] == pytest.approx(K * (1 - NU ** 2), rel=1e-7)
    nu = r.parameters["nu"]
    assert nu["status"] == "fixed: not identifiable" and nu["value"] == NU and nu["value_source"] == "assumed value"
    assert r.parameters["R"]["status"] == "fixed" and r.parameters["R"]["value"] == R
    assert r.to_dict()["residual_lag1_correlation"] < 0  # so the interval is not inflated
    lo, hi = r.derived["K"]["ci_asymptotic"]
    assert lo == pytest.approx(K - Z95 * se, rel=1e-6) and hi == pytest.approx(K + Z95 * se, rel=1e-6)
    lo, hi = E["ci_asymptotic"]
    assert lo == pytest.approx((K - Z95 * se) * (1 - NU ** 2), rel=1e-6)
    # The profile and bootstrap intervals bracket the estimate.
    for kind in ("ci_profile", "ci_bootstrap"):
        lo, hi = r.derived["K"][kind]
        assert lo < K < hi, kind
    assert r.overall["rmse_N"] == pytest.approx(math.sqrt(sse / len(F)), rel=1e-6)
    np.testing.assert_allclose(r.values, [E["value"], NU, R])
    # Predicting a trial not fitted: the law at the identified K.
    held, ch = make_trial("chair", 50, 2.0, 3)
    p = r.predict(held)
    np.testing.assert_allclose(p["predicted"], r.derived["K"]["value"] * ch, rtol=1e-12)
    np.testing.assert_array_equal(p["measured"], held["measured_force"])


def test_fit_errors_are_input_errors():
    a, _ = make_trial("walk", 20, 0.0, 1)
    no_area = dict(a, channels={"S_medial": a["channels"]["S"]})
    with pytest.raises(kneesim.InputError, match=r"contact law 'hertz' needs input channel 'S', which trial 'walk' does not have"):
        kneesim.fit_contact_law([no_area], bootstrap_samples=0)
    backwards = dict(a, time=a["time"][::-1].copy())
    with pytest.raises(kneesim.InputError, match=r"^fit_contact_law/trials\[0\]: .*increasing"):
        kneesim.fit_contact_law([backwards], bootstrap_samples=0)
    with pytest.raises(kneesim.InputError, match=r"no contact law named 'herz'|'herz'"):
        kneesim.fit_contact_law([a], law="herz", plugins=["hertz"], bootstrap_samples=0)
    with pytest.raises(kneesim.InputError, match=r"expected a key 'measured_force'"):
        kneesim.fit_contact_law([{"time": a["time"], "channels": a["channels"]}])
