"""The one request-and-answer loop every ground-station protocol uses (Exchange), on a fake
clock so that its timing is exact."""

from __future__ import annotations

import pytest

from validator.mavlink import connection
from validator.mavlink.connection import Exchange


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now


class SilentVehicle:
    """Answers with ``answers`` in turn (None = silence, waited out to the deadline, or for a
    moment when it has passed: a real wait always takes some time)."""

    timeout_s = 2.0

    def __init__(self, clock: FakeClock, answers: list[str | None]) -> None:
        self.clock = clock
        self.answers = answers
        self.deadlines: list[float] = []

    def recv(self, types, deadline, accept):
        self.deadlines.append(deadline)
        answer = self.answers.pop(0) if self.answers else None
        if answer is None:
            self.clock.now = max(self.clock.now + 0.001, deadline)
        return answer


@pytest.fixture()
def clock(monkeypatch):
    c = FakeClock()
    monkeypatch.setattr(connection.time, "monotonic", c.monotonic)
    return c


def test_silence_repeats_the_request_until_the_timeout(clock):
    vehicle = SilentVehicle(clock, [])
    sent = []
    answers = list(Exchange(vehicle, lambda: sent.append(clock.now), ("X",), None, 0.5))
    # a request every 0.5 s from 100.0; the last wait is cut at the 2 s timeout
    assert sent == [100.0, 100.5, 101.0, 101.5, 102.0]
    assert answers == [None] * 5
    assert max(vehicle.deadlines) == 102.0  # never waits past the timeout


def test_progress_gives_the_vehicle_another_timeout(clock):
    vehicle = SilentVehicle(clock, [None, None, "working", None, None, None, None, None])
    exchange = Exchange(vehicle, lambda: None, ("X",), None, 1.0)
    seen = []
    for answer in exchange:
        seen.append((clock.now, answer))
        if answer == "working":
            exchange.progress()
    assert seen[2] == (102.0, "working")
    # without progress() the exchange would have ended just after 102 s; it ends 2 s later
    assert [t for t, _ in seen] == pytest.approx([101.0, 102.0, 102.0, 103.0, 104.0, 104.001])
