"""The real ArduCopter firmware flying a realistic plan while the link to it fails (the lossy
relay between): it flies on through a gap and the report says what the track misses; a link
that stays down ends the run with a verdict naming what the vehicle's own failsafe does; a
link that comes back too late lands the vehicle.

Skipped without an ArduCopter SITL binary (``$ARDUPILOT_SITL``, else ``/opt/sitl/arducopter``).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from tests.validator.mavlink.sitl_binaries import REPO, plan_for, sitl_binary
from validator.autopilot.param_file import read_params
from validator.mavlink.driver import default_time_limit_s, fly_and_score, wait_until_ready
from validator.mavlink.link import Link
from validator.mavlink.lossy_relay import LinkFaults, LossyRelay
from validator.mavlink.sitl_process import ardupilot_sitl, find_defaults, sped_up_link_params
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.validation import validate_mission

BINARY = sitl_binary("ARDUPILOT_SITL", Path("/opt/sitl/arducopter"))
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl"), pytest.mark.skipif(
    BINARY is None,
    reason="no ArduCopter SITL binary: build ArduCopter 4.5 SITL for this machine and set "
           "ARDUPILOT_SITL=/path/to/build/sitl/bin/arducopter (or link it at "
           "/opt/sitl/arducopter) to run the real-autopilot tests")]
SPEEDUP = 10.0
LAND = 9  # ArduCopter's custom mode


@pytest.fixture(scope="module")
def realistic(tmp_path_factory: pytest.TempPathFactory):
    site = REPO / "samples" / "realistic.yaml"
    plan, params = plan_for(tmp_path_factory.mktemp("realistic"), site)
    return validate_mission(plan, site), read_params(params)


@pytest.fixture()
def sitl_url(realistic):
    v, _ = realistic
    assert BINARY is not None
    with ardupilot_sitl(BINARY, (v.plan.home_lat_deg, v.plan.home_lon_deg, v.plan.home_alt_m),
                        speedup=SPEEDUP, defaults=find_defaults(BINARY)) as url:
        with Link(url, timeout_s=30) as link:
            wait_until_ready(link)
        yield url


def fly(realistic, relay: LossyRelay, *, cut_after_s: float, cut_for_s: float | None,
        timeout_s: float, back_once_landing: bool = False):
    """Fly the plan through ``relay``, cutting the link ``cut_after_s`` wall seconds after
    AUTO for ``cut_for_s`` (None: for good), or, with ``back_once_landing``, until the tool
    has declared the link lost and is commanding LAND into the silence."""
    v, params = realistic
    landing = threading.Event()

    def cut() -> None:
        time.sleep(cut_after_s)
        relay.cut()
        if back_once_landing:
            # timed on the tool's own step, not on wall seconds: on a loaded machine a fixed
            # gap can end before the tool gives up on the link, or after it stops asking
            landing.wait(60.0)
            time.sleep(0.5)
            relay.restore()
        elif cut_for_s is not None:
            time.sleep(cut_for_s)
            relay.restore()

    cutter = threading.Thread(target=cut, daemon=True)

    def progress(text: str) -> None:
        if text.startswith("AUTO"):
            cutter.start()
        elif text.startswith("link lost: commanding"):
            landing.set()

    profile = make_profile("arducopter", site_limits(v.site))
    # as validate-mission --sitl-binary does: our wall-clock heartbeats are sparse at x10
    sent = {**sped_up_link_params(SPEEDUP, px4=False), **params}
    result = fly_and_score(v.plan, v.site, v.flight, relay.url,
                           time_limit_s=default_time_limit_s(v.flight, profile),
                           timeout_s=timeout_s, params=sent, progress=progress)
    cutter.join()
    return result


def messages(result) -> list[str]:
    return [f.message for f in result.report.findings]


def test_arducopter_flies_on_through_a_gap_and_the_report_says_what_the_track_misses(
        realistic, sitl_url):
    with LossyRelay(sitl_url, LinkFaults.lossy(0.05), seed=1) as relay:
        result = fly(realistic, relay, cut_after_s=3.0, cut_for_s=1.0, timeout_s=5.0)
    assert result.telemetry.end_reason == "landed"
    assert not result.telemetry.link_lost
    gaps = [m for m in messages(result) if m.startswith("the link dropped")]
    assert len(gaps) == 1
    assert result.telemetry.gaps() and max(g[1] for g in result.telemetry.gaps()) > 5.0
    assert not result.report.violations  # clear of every zone, scored through the gap


def test_a_link_down_for_good_names_arducopters_own_failsafe(realistic, sitl_url):
    with LossyRelay(sitl_url, LinkFaults.lossy(0.05), seed=2) as relay:
        result = fly(realistic, relay, cut_after_s=3.0, cut_for_s=None, timeout_s=5.0)
    assert result.telemetry.end_reason == "link lost"
    [lost] = [f for f in result.report.findings if f.message.startswith("link lost")]
    assert lost.severity == "violation"
    assert "it did not come back within 5 s" in lost.message
    # the plan's .param sets ArduCopter's GCS failsafe to SmartRTL (or Land), and the
    # verdict says what the vehicle will do on its own
    assert "SmartRTL" in lost.message and "(FS_GCS_ENABLE 4: SmartRTL or Land)" in lost.message


def test_a_link_back_too_late_lands_arducopter(realistic, sitl_url):
    with LossyRelay(sitl_url, LinkFaults.lossy(0.05), seed=3) as relay:
        result = fly(realistic, relay, cut_after_s=3.0, cut_for_s=None, timeout_s=5.0,
                     back_once_landing=True)
    [lost] = [m for m in messages(result) if m.startswith("link lost")]
    assert "the link came back and the vehicle accepted LAND" in lost
    assert not result.telemetry.armed[-1]  # the descent was recorded down to the disarm
    with Link(sitl_url, timeout_s=10) as link:
        hb = link.recv(["HEARTBEAT"], time.monotonic() + 5)
        assert hb is not None and hb.custom_mode == LAND
