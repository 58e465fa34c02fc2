"""The plotly figure inside a written HTML view (``plan-mission --html``, ``validate-mission
--html``): what plotly.js is given, read back as JSON for the tests that check its layers."""

from __future__ import annotations

import json
from typing import Any

from validator.view.page import DIV_ID


def page_figure(page: str) -> dict[str, Any]:
    """The ``data`` and ``layout`` the page passes to ``Plotly.newPlot``."""
    decoder = json.JSONDecoder()
    data, end = decoder.raw_decode(page, page.index("[", page.index(f'"{DIV_ID}",')))
    layout, _ = decoder.raw_decode(page, page.index("{", end))
    return {"data": data, "layout": layout}


def layer(figure: dict[str, Any], name: str) -> list[dict[str, Any]]:
    """The traces of one layer (``meta.layer``, :mod:`validator.view.layers`)."""
    return [t for t in figure["data"] if t.get("meta", {}).get("layer") == name]
