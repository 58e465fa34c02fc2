"""An interactive view of a mission: plan, zones, fence and flights in one self-contained HTML
page (plotly), written by ``plan-mission --html`` and ``validate-mission --html``.

- :mod:`.inputs`: what a view shows (:class:`ViewInputs`); optional layers (failsafe paths,
  wind, a fault flight) are fields other checks fill (:func:`failsafe_paths` from a failsafe
  audit, :func:`fault_mark` from a fault flight's report);
- :mod:`.layers`: the still map layers as plotly traces;
- :mod:`.timeline`: the flights on a time slider, the node served and the rates;
- :mod:`.page`: the figure and the HTML page (:func:`view_html`, :func:`write_view`).
"""

from validator.view.inputs import (
    STILL_AIR,
    FailsafePath,
    FaultMark,
    TrackLayer,
    ViewInputs,
    Wind,
    failsafe_paths,
    fault_mark,
    validation_inputs,
)
from validator.view.page import view_figure, view_html, write_view

__all__ = ["STILL_AIR", "FailsafePath", "FaultMark", "TrackLayer", "ViewInputs", "Wind",
           "failsafe_paths", "fault_mark", "validation_inputs", "view_figure", "view_html",
           "write_view"]
