"""Fig. 3 of a solution: what the map and the slot panel draw."""

from __future__ import annotations

import io

import matplotlib.image as mpimg
import numpy as np
import pytest
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle

from mission_planner.figure import figure_png, solution_figure
from mission_planner.mission import build_mission
from tests.mission_planner.solutions import circle_tour, make_site


def test_map_colours_each_leg_by_its_gn_and_draws_three_circles_per_nfz():
    site = make_site()
    sol = circle_tour(site)
    fig = solution_figure(sol, build_mission(sol))
    ax, bx = fig.axes[0], fig.axes[1]
    legs = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(legs) == 1 and len(legs[0].get_segments()) == site.slots
    colours = legs[0].get_colors()
    # slots served to the same GN share a colour, different GNs differ
    same = sol.schedule[:, None] == sol.schedule[None, :]
    equal = np.all(np.isclose(colours[:, None, :], colours[None, :, :]), axis=2)
    np.testing.assert_array_equal(same, equal)
    circles = [p for p in ax.patches if isinstance(p, Circle)]
    assert len(circles) == 3 * site.num_nfzs
    radii = sorted({round(c.get_radius(), 6) for c in circles})
    assert radii[0] == 30.0 and radii[1] == 32.0 and radii[2] > 32.0
    assert len(bx.get_lines()) == 1 and len(fig.axes) == 3  # δ and its twin axis with p


def test_png_is_the_drawn_figure_at_its_size():
    site = make_site()
    fig = solution_figure(circle_tour(site))
    width_in, height_in = fig.get_size_inches()
    image = mpimg.imread(io.BytesIO(figure_png(fig)), format="png")
    assert image.shape[0] / image.shape[1] == pytest.approx(height_in / width_in, rel=0.01)
    # something was drawn: not a blank canvas, and the legs' colours are in it
    assert image[..., :3].std() > 0.05
    leg_colour = fig.axes[0].collections[0].get_colors()[0][:3]
    assert np.any(np.all(np.abs(image[..., :3] - leg_colour) < 0.02, axis=-1))


def _legend_overlaps_data(fig) -> list[str]:
    """Names of the axes whose plotting area a legend of the figure covers."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    legends = [lg for ax in fig.axes if (lg := ax.get_legend()) is not None] + fig.legends
    assert legends, "the figure has no legend"
    out = []
    for lg in legends:
        box = lg.get_window_extent(renderer)
        out += [ax.get_title() or "axes" for ax in fig.axes
                if box.overlaps(ax.get_window_extent(renderer))]
    return out


def test_the_legends_stay_off_the_data():
    from mission_planner.study.plots import plot_fig3_map, plot_fig3_slots

    site = make_site()
    sol = circle_tour(site)
    for fig in (solution_figure(sol, build_mission(sol)), plot_fig3_map([sol]),
                plot_fig3_slots([sol])):
        assert _legend_overlaps_data(fig) == []
