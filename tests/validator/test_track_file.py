"""Recorded tracks written and read back (validator.track_file)."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from validator.errors import InputError
from validator.track_file import COLUMNS, RecordedTrack, read_track, write_track


def _track(n: int = 5) -> RecordedTrack:
    t = np.arange(n) * 0.25 - 0.5
    return RecordedTrack(
        t_s=t, lat_deg=37.5 + t * 1e-6, lon_deg=127.0 - t * 1e-6, alt_m=t * 2.0,
        vel_ned_mps=np.column_stack([t, -t, 0.1 * t]),
        item=np.array([-1, -1, 0, 2, 2][:n], dtype=np.int64),
        armed=np.array([False, True, True, True, False][:n]),
        fence_breach=np.array([False, False, False, True, False][:n]),
    )


@pytest.mark.parametrize("name", ["flown.csv", "flown.csv.gz"])
def test_a_track_reads_back_as_written(tmp_path, name):
    rec = _track()
    path = tmp_path / name
    write_track(path, rec, ("plan x.plan",))
    back = read_track(path)
    assert back.t_s == pytest.approx(rec.t_s)
    assert back.lat_deg == pytest.approx(rec.lat_deg, abs=1e-8)
    assert back.vel_ned_mps == pytest.approx(rec.vel_ned_mps, abs=0.005)
    assert back.item.tolist() == rec.item.tolist()
    assert back.armed.tolist() == rec.armed.tolist()
    assert back.fence_breach.tolist() == rec.fence_breach.tolist()
    assert back.disarmed_s == pytest.approx(0.5)


def test_when_the_vehicle_left_the_mission_reads_back(tmp_path):
    rec = _track()
    left = RecordedTrack(**{**rec.__dict__, "left_mission": np.array([0, 0, 0, 1, 1], bool)})
    write_track(tmp_path / "left.csv", left)
    assert read_track(tmp_path / "left.csv").left_mission_s == pytest.approx(0.25)
    write_track(tmp_path / "stayed.csv", rec)
    assert read_track(tmp_path / "stayed.csv").left_mission_s is None


def test_a_track_file_written_before_left_mission_still_reads(tmp_path):
    path = tmp_path / "old.csv"
    path.write_text(",".join(COLUMNS[:-1]) + "\n0,37.5,127.0,0,0,0,0,-1,1,0\n")
    back = read_track(path)
    assert back.item.tolist() == [-1] and back.left_mission_s is None


def test_gz_is_compressed(tmp_path):
    write_track(tmp_path / "a.csv.gz", _track())
    text = gzip.decompress((tmp_path / "a.csv.gz").read_bytes()).decode()
    assert text.splitlines()[0] == ",".join(COLUMNS)


@pytest.mark.parametrize("text, message", [
    ("t_s,lat\n0,1\n", "not a track file"),
    (",".join(COLUMNS) + "\n", "no samples"),
    (",".join(COLUMNS) + "\n0,1,2,3,4,5,6,7,8,0\n", "line 2: expected 11 finite numbers"),
    (",".join(COLUMNS) + "\n0,nan,2,3,4,5,6,7,1,0,0\n", "line 2: expected 11 finite numbers"),
    (",".join(COLUMNS) + "\n1,1,2,3,4,5,6,7,1,0,0\n0,1,2,3,4,5,6,7,1,0,0\n", "must not decrease"),
    (",".join(COLUMNS) + "\n0,1,2,3,4,5,6,7,1,0,1\n1,1,2,3,4,5,6,7,1,0,0\n",
     "left_mission must not go back to 0"),
    (",".join(COLUMNS[:-1]) + "\n0,1,2,3,4,5,6,7,1,0,0\n", "line 2: expected 10 finite numbers"),
    # values no flight records: had been scored (a latitude of 91: 5,127 km off the legs)
    (",".join(COLUMNS) + "\n0,1,2,3,4,5,6,7,1,0,0\n1,91,2,3,4,5,6,7,1,0,0\n",
     "line 3: lat_deg 91 beyond ±90"),
    (",".join(COLUMNS) + "\n0,1,-181,3,4,5,6,7,1,0,0\n", "line 2: lon_deg -181 beyond ±180"),
    (",".join(COLUMNS) + "\n0,1,2,1e12,4,5,6,7,1,0,0\n", "line 2: alt_m 1e\\+12 beyond"),
    (",".join(COLUMNS) + "\n0,1,2,3,4,5,6,1e20,1,0,0\n", "line 2: item 1e\\+20 beyond"),
    (",".join(COLUMNS) + "\n0,1,2,3,4,5,6,7.5,1,0,0\n", "line 2: item 7.5 is no item index"),
])
def test_a_bad_track_file_is_one_input_error_naming_it(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        read_track(path)
    assert str(path) in str(err.value)


def test_a_corrupt_gz_is_an_input_error(tmp_path):
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(b"not gzip at all")
    with pytest.raises(InputError, match="not a gzip-compressed track file"):
        read_track(path)


def test_track_without_a_flight_is_refused(tmp_path, capsys):
    from validator.cli import validate_mission_main

    status = validate_mission_main(["x.plan", "--site", "s.yaml", "--track",
                                    str(tmp_path / "t.csv")])
    assert status == 2
    assert "--track" in capsys.readouterr().err
    assert not (tmp_path / "t.csv").exists()
