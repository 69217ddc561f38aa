"""Width-curve features on synthetic curves whose peak, plateau and settling time are known."""

import math

import numpy as np
import pytest

from warp_cut.cut.wound.width_curve import analyse_width, width_curve_metrics

DT = 1e-3
T = np.arange(0, 2001) * DT  # 0 .. 2 s


def _rise_fall(t, peak_t=0.2, peak=3e-3, plateau=1e-3, fall_end=0.6):
    """Linear rise to the peak, linear fall to the plateau, flat after."""
    return np.interp(t, [0.0, peak_t, fall_end, t[-1]], [0.0, peak, plateau, plateau])


def test_piecewise_linear_curve():
    a = analyse_width(T, _rise_fall(T), band=0.05)
    assert a.peak_width == pytest.approx(3e-3) and a.peak_time == pytest.approx(0.2)
    assert a.plateau_width == pytest.approx(1e-3, rel=1e-12)
    assert a.plateau_start == pytest.approx(1.6)
    # the fall crosses plateau + 5 % where 3 - 2 (t - 0.2) / 0.4 = 1.05 (mm): t = 0.59 s
    assert a.settling_time == pytest.approx(0.59, abs=DT)


def test_exponential_decay_to_a_plateau():
    # w = P + (W - P) exp(-(t - tp) / tau) after a linear rise: settles where
    # (W - P) exp(-(t - tp) / tau) = band P, i.e. t = tp + tau ln((W - P) / (band P))
    tp, W, P, tau, band = 0.1, 4e-3, 1.5e-3, 0.08, 0.02
    w = np.where(T < tp, W * T / tp, P + (W - P) * np.exp(-(T - tp) / tau))
    a = analyse_width(T, w, band=band)
    assert a.peak_time == pytest.approx(tp) and a.peak_width == pytest.approx(W)
    assert a.plateau_width == pytest.approx(P, rel=1e-6)
    assert a.settling_time == pytest.approx(tp + tau * math.log((W - P) / (band * P)), abs=DT)


def test_noise_inside_the_band_does_not_delay_settling(rng):
    w = _rise_fall(T) + rng.uniform(-1, 1, T.size) * 0.02e-3  # +-2 % of the plateau
    a = analyse_width(T, w, band=0.05)
    assert a.settling_time == pytest.approx(0.59, abs=0.01)
    assert a.plateau_width == pytest.approx(1e-3, rel=0.01)


def test_a_curve_still_moving_has_not_settled_and_samples_before_the_cut_are_left_out():
    assert analyse_width(T, T * 1e-3).settling_time is None
    w = _rise_fall(T)
    w_cut = np.where(T < 0.05, np.nan, w)  # no incision yet
    a = analyse_width(T, w_cut)
    # default band 2 %: 3 - 2 (t - 0.2) / 0.4 = 1.02 at t = 0.596 s
    assert a.peak_time == pytest.approx(0.2) and a.settling_time == pytest.approx(0.596, abs=DT)


def test_metrics_names_carry_units():
    m = width_curve_metrics(T, _rise_fall(T))
    assert set(m) == {"peak_m", "peak_time_s", "plateau_m", "plateau_start_s",
                      "settling_time_s", "band"}
    assert m["band"] == 0.02 and m["settling_time_s"] == pytest.approx(0.596, abs=DT)
    assert width_curve_metrics(T[:2], T[:2]) is None


@pytest.mark.parametrize("t, w, kw, match", [
    ([0, 1], [0, 1], {}, "at least 3"),
    ([0, 1, 2], [0, 1], {}, "same length"),
    ([0, 2, 1], [0, 1, 2], {}, "increasing"),
    ([0, 1, 2], [0, 1, 2], {"band": 0}, "band"),
    ([0, 1, 2], [0, 1, 2], {"plateau_fraction": 1.5}, "plateau_fraction"),
])
def test_bad_input_is_refused(t, w, kw, match):
    with pytest.raises(ValueError, match=match):
        analyse_width(t, w, **kw)
