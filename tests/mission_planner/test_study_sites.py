"""random_site: the seeded paper-style site generator."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from mission_planner.study.sites import max_zones, random_site
from validator.errors import InputError


def test_same_seed_gives_the_same_site() -> None:
    a, b = random_site(7), random_site(7)
    np.testing.assert_array_equal(a.gn_xy_m, b.gn_xy_m)
    np.testing.assert_array_equal(a.nfz_xy_m, b.nfz_xy_m)
    np.testing.assert_array_equal(a.home_xy_m, b.home_xy_m)


def test_other_seeds_give_other_sites() -> None:
    centres = {tuple(random_site(s).nfz_xy_m.ravel()) for s in range(20)}
    assert len(centres) == 20


def test_defaults_are_the_papers_section_iv() -> None:
    site = random_site(0)
    assert (site.num_gns, site.num_nfzs, site.slots) == (4, 3, 50)
    assert site.period_s == 50.0 and site.altitude_m == 30.0 and site.max_speed_mps == 30.0
    np.testing.assert_allclose(site.nfz_radius_m, 30.0)
    assert site.buffer_m == 0.0
    assert site.p_avg_w == pytest.approx(0.1)
    assert site.p_peak_w == pytest.approx(4 * site.p_avg_w)
    assert site.beta0 == pytest.approx(1e-3) and site.noise_w == pytest.approx(1e-10)


@pytest.mark.parametrize("seed", range(40))
def test_zones_inside_the_area_apart_and_gns_and_home_outside(seed: int) -> None:
    area, radius, buffer = 400.0, 45.0, 5.0
    site = random_site(seed, num_gns=6, num_nfzs=5, radius_m=radius, buffer_m=buffer)
    c = site.nfz_xy_m
    assert np.all(c >= radius) and np.all(c <= area - radius)
    for i, j in itertools.combinations(range(site.num_nfzs), 2):
        assert np.linalg.norm(c[i] - c[j]) >= 2 * radius
    assert np.all((site.gn_xy_m >= 0) & (site.gn_xy_m <= area))
    gn_dist = np.linalg.norm(site.gn_xy_m[:, None, :] - c[None, :, :], axis=-1)
    assert np.all(gn_dist >= radius)
    assert np.all(np.linalg.norm(c - site.home_xy_m, axis=1) >= radius + buffer)


def test_more_zones_keep_the_first_ones() -> None:
    few, more = random_site(11, num_nfzs=2), random_site(11, num_nfzs=5)
    np.testing.assert_array_equal(more.nfz_xy_m[:2], few.nfz_xy_m)


def test_zones_that_cannot_fit_are_refused_naming_the_count() -> None:
    with pytest.raises(InputError, match="num_nfzs"):
        random_site(1, num_nfzs=10, radius_m=100.0)


# the widest spread of n points in the unit square (Schaer, Meir and others; proven optimal),
# the least side at which n zones still lie apart
BEST_SPREAD = {2: math.sqrt(2), 3: math.sqrt(6) - math.sqrt(2), 4: 1.0, 5: math.sqrt(2) / 2,
               6: math.sqrt(13) / 6, 7: 4 - 2 * math.sqrt(3),
               8: (math.sqrt(6) - math.sqrt(2)) / 2, 9: 0.5}


@pytest.mark.parametrize(("count", "spread"), BEST_SPREAD.items())
def test_the_packing_bound_never_refuses_zones_that_fit(count: int, spread: float) -> None:
    # the largest radius at which `count` zones fit: 2 r = (area - 2 r) * spread
    area = 400.0
    radius = area * spread / (2 * (1 + spread))
    assert max_zones(radius, area) >= count


@pytest.mark.parametrize("k", range(1, 16))
def test_the_packing_bound_allows_a_full_grid_of_touching_zones(k: int) -> None:
    assert max_zones(400.0 / (2 * k), 400.0) >= k * k


def test_zones_that_cannot_lie_apart_are_refused_before_any_draw() -> None:
    # three 190 m zones: at most one lies in the 400 m square
    with pytest.raises(InputError, match="num_nfzs: 3 zones of radius 190 m cannot lie apart "
                                         r"in the 400 m square of the sites \(at most 1 fit\)"):
        random_site(0, num_nfzs=3, radius_m=190.0)


def test_a_count_the_bound_lets_pass_may_still_fail_its_draws() -> None:
    # three 110 m zones pass the bound but fit only up to 101.7 m: the draws say so
    assert max_zones(110.0, 400.0) >= 3
    with pytest.raises(InputError, match="num_nfzs: cannot place 3"):
        random_site(0, num_nfzs=3, radius_m=110.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"radius_m": -1.0}, "radius_m"),
        ({"num_gns": 0}, "num_gns"),
        ({"slots": 0}, "slots"),
        ({"num_nfzs": -1}, "num_nfzs"),
        ({"buffer_m": -0.5}, "buffer_m"),
        ({"area_m": 50.0}, "area_m"),
    ],
)
def test_bad_parameters_are_refused_naming_the_field(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(InputError, match=field):
        random_site(0, **kwargs)  # type: ignore[arg-type]


def test_negative_seed_is_refused() -> None:
    with pytest.raises(InputError, match="seed"):
        random_site(-1)
