"""The buffer that matches the air: the track-deviation model pinned to real SITL wind flights.

``tests/data/arducopter-sitl-wind/flights.json`` (plans with the site's buffer) and
``flights-wind-buffer.json`` (plans with the wind buffer): ArduCopter 4.5.6 SITL flights in SITL
wind (``benchmarks/sitl_wind_flights.py``), summary figures per flight.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from validator.wind import Wind
from validator.wind_track import (
    DEVIATION_MODEL,
    buffer_share,
    fit_deviation_model,
    wind_buffer_m,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "arducopter-sitl-wind"


FITTED = ("flights.json", "flights-wind-buffer.json")  # the flights the model is fitted to


def _flights(names: tuple[str, ...] = FITTED) -> list[dict]:
    return [f for name in names for f in json.loads((DATA / name).read_text())]


def _deviation(f: dict) -> float:
    """Replayed minus flown clearance at the zone the flown track came closest to."""
    flown, replayed = f["flown_clearance_m"], f["replayed_clearance_m"]
    closest = min(flown, key=flown.get)
    return float(replayed[closest] - flown[closest])


def _aware(flights: list[dict]) -> list[dict]:
    return [f for f in flights if f["plan"] == "aware" and f["flown_clearance_m"]]


def test_the_model_is_the_fit_of_the_recorded_flights() -> None:
    aware = _aware(_flights())
    assert len(aware) >= 50 and sum(f["wind_speed_mps"] > 0 for f in aware) >= 40
    assert len({f["site"] for f in aware}) >= 3
    fit = fit_deviation_model([f["wind_speed_mps"] for f in aware],
                              [f["turbulence_mps"] for f in aware],
                              [_deviation(f) for f in aware])
    # refit and pin when the data changes (to the float: the fit's last bits move with the
    # linear-algebra library's build)
    assert dataclasses.astuple(fit) == pytest.approx(dataclasses.astuple(DEVIATION_MODEL),
                                                     rel=1e-9)


def test_the_model_covers_its_quantile_of_the_flights() -> None:
    aware = _aware(_flights())
    covered = [_deviation(f) <= DEVIATION_MODEL.deviation_m(
        Wind(f["wind_speed_mps"], f["wind_from_deg"], f["turbulence_mps"])) + 1e-9
        for f in aware]
    assert sum(covered) / len(covered) >= DEVIATION_MODEL.quantile


def test_fit_on_known_data() -> None:
    wind = [0.0, 2.0, 4.0, 6.0, 8.0] * 4
    turb = [0.0, 0.5, 1.0, 1.5, 2.0] * 4
    dev = [0.1 + 0.05 * w + 0.1 * t for w, t in zip(wind, turb, strict=True)]
    fit = fit_deviation_model(wind, turb, dev)
    assert fit.deviation_m(Wind(8.0, 0.0, 2.0)) == pytest.approx(0.1 + 0.4 + 0.2)
    assert fit.deviation_m(None) == pytest.approx(0.1)
    # a slope that comes out negative is clipped: more wind never brings the track away
    fit = fit_deviation_model(wind, turb, [0.5 - 0.05 * w for w in wind])
    assert fit.per_wind == 0.0 and fit.per_turbulence == 0.0


def test_the_buffer_grows_by_the_deviation_and_the_reports_say_its_share() -> None:
    wind = Wind(8.0, 45.0, 2.0)
    d = DEVIATION_MODEL.deviation_m(wind)
    assert 3.0 + d <= wind_buffer_m(3.0, wind) <= 3.0 + d + 0.01  # up to the centimetre
    assert round(wind_buffer_m(3.0, wind) * 100) == pytest.approx(wind_buffer_m(3.0, wind) * 100)
    share = buffer_share(3.0, wind)
    assert share["share_of_buffer"] == pytest.approx(d / 3.0)


@pytest.mark.parametrize("campaign", ["flights-q99-still-check.json", "flights-berth.json",
                                      "flights-families.json", "flights-wind-corners.json",
                                      "flights-speed-change.json", "flights-probe.json",
                                      "flights-gusts.json", "flights-slots.json",
                                      "flights-reach.json", "flights-drag.json",
                                      "flights-starts.json", "flights-first-fit.json"])
def test_the_model_covers_the_flights_it_was_not_fitted_to(campaign: str) -> None:
    """The campaigns flown after the fit (the third: plans with the 0.99 buffer and the
    still-path check; the fourth: plan-mission's plans with the GPS-loss berth, issue 27; the
    sixth: both wind path families searched, the berth one step in wind, transits commanded
    what the wind leaves; the seventh: the wind corner lag; the eighth: the speed change at a
    corner; the ninth: the berth's probe plan; the eleventh: legs commanded the airspeed held
    through the gusts; the twelfth: slots laid where the model flies each leg; the thirteenth:
    a speed change at a corner as far as half the S-curve's constant part takes it; the
    fourteenth: the lean limit with the SITL quad's drag per body axis; the fifteenth: the
    still-air path searched from the start that fits better; the sixteenth: the berth's probe
    ending at its first fit): no
    flown point of a plan made for its wind came inside the site's buffer, and no track
    deviated more than the model says."""
    aware = [f for f in _aware(_flights((campaign,))) if f["wind_speed_mps"] > 0]
    assert len(aware) >= 20
    assert all(_deviation(f) <= DEVIATION_MODEL.deviation_m(
        Wind(f["wind_speed_mps"], f["wind_from_deg"], f["turbulence_mps"])) + 1e-9
        for f in aware)
    assert all(min(f["flown_clearance_m"].values()) >= f["buffer_m"] for f in aware)


def test_the_fifth_campaign_kept_the_buffer() -> None:
    """realistic.yaml in 8 winds, planned with the sharp-corner lag: every flight kept the
    site's buffer. (One track, 6 m/s from 135°, deviated 0.47 m where the 0.99 model says
    0.39, 24 m from the zone: one of 59 flights after the fit, as a 0.99 quantile allows.)"""
    aware = [f for f in _aware(_flights(("flights-corner-lag.json",)))
             if f["wind_speed_mps"] > 0]
    assert len(aware) >= 8
    assert all(min(f["flown_clearance_m"].values()) >= f["buffer_m"] for f in aware)


def test_a_wind_beyond_the_fitted_flights_is_said_to_be_extrapolated() -> None:
    from validator.wind_track import extrapolation_warning

    assert extrapolation_warning(None) is None
    assert extrapolation_warning(Wind(8.0, 45.0, 2.0)) is None  # the strongest flown
    assert buffer_share(3.0, Wind(8.0, 45.0, 2.0))["extrapolated"] is False
    stronger = extrapolation_warning(Wind(9.0, 45.0, 1.0))
    assert stronger is not None and "winds up to 8 m/s with turbulence up to 2 m/s" in stronger
    assert "in 9 m/s from 45°, turbulence 1 m/s its" in stronger
    assert "--sitl-binary --wind" in stronger
    px4 = extrapolation_warning(Wind(9.0, 45.0, 1.0), px4=True)
    assert px4 is not None and "SIH has no wind" in px4 and "--sitl-binary" not in px4
    gustier = Wind(4.0, 90.0, 3.0)
    assert extrapolation_warning(gustier) is not None
    assert buffer_share(3.0, gustier)["extrapolated"] is True
