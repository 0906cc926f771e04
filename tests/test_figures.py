"""Figures a newcomer reads unaided (issue 28, item 9): the legend (or a colour bar) names
every kind of mark drawn, every text is legible at the saved size, one title per panel.

Each plotting module tags what it draws with a ``gid``: a phrase of the legend entry (or colour
bar label) that explains it, or ``"frame"`` for reference lines and boxes. The check walks every
axes of a figure (insets included) and every artist drawn in it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import infoseek.envs
from infoseek.envs.rendering import SearchRenderer
from infoseek.experiments.clairvoyant import CLAIRVOYANT_LABEL
from infoseek.experiments.columns import TrialView
from infoseek.experiments.plot import IQR_LABEL, SE_LABEL, fig1_figure
from infoseek.experiments.studies.ablation import GapRow, ablation_figure

#: Smallest font (points) of any text at the saved size (the figures are saved at >= 100 dpi).
SMALLEST_FONT = 6.0


def _explanations(figure: Any) -> list[str]:
    """Every legend text of the figure and the labels of its colour bars."""
    texts = []
    for axes in figure.get_axes():
        legend = axes.get_legend()
        if legend is not None:
            texts += [text.get_text() for text in legend.get_texts()]
        if hasattr(axes, "_colorbar"):
            texts += [axes.get_ylabel(), axes.get_xlabel()]
    for legend in figure.legends:
        texts += [text.get_text() for text in legend.get_texts()]
    return [text for text in texts if text]


def _marks(axes: Any) -> list[Any]:
    """The artists drawn in ``axes`` and its insets (visible ones with something to show)."""
    artists = [*axes.lines, *axes.collections, *axes.patches, *axes.images, *axes.artists]
    for child in axes.child_axes:
        if child.get_visible():
            artists += _marks(child)
    return [artist for artist in artists if artist.get_visible()]


def unexplained_marks(figure: Any) -> list[str]:
    """Artists whose ``gid`` is missing or names no legend entry / colour bar label."""
    explanations = _explanations(figure)
    problems = []
    for axes in figure.get_axes():
        insets = {child for parent in figure.get_axes() for child in parent.child_axes}
        if hasattr(axes, "_colorbar") or axes in insets:
            continue  # colour bars explain, insets are checked with their parent
        for artist in _marks(axes):
            gid = artist.get_gid()
            if gid == "frame":
                continue
            if not gid or not any(gid in text for text in explanations):
                problems.append(f"{axes.get_title()!r}: {type(artist).__name__} gid={gid!r}")
    return problems


def small_texts(figure: Any) -> list[str]:
    """Visible texts smaller than :data:`SMALLEST_FONT` points."""
    from matplotlib.text import Text

    return [
        f"{text.get_text()!r} at {text.get_fontsize():.1f} pt"
        for text in figure.findobj(match=Text)
        if text.get_visible() and text.get_text() and text.get_fontsize() < SMALLEST_FONT
    ]


def _records(rng: np.random.Generator) -> list[TrialView]:
    """Synthetic trials of every group the three panels of Fig. 1 draw."""
    groups = [
        ("single", 4),
        ("pairwise", 4),
        ("horizon", 4),
        (CLAIRVOYANT_LABEL, 4),
        ("random", 4),
        ("lawnmower", 4),
        ("pairwise", 2),
        ("horizon", 2),
    ]
    records = []
    for planner, n_agents in groups:
        for trial in range(12):
            ttl = int(rng.integers(3, 12))
            mass = np.clip(np.arange(16) / ttl, 0.0, 1.0)
            records.append(
                TrialView(
                    planner=planner,
                    n_agents=n_agents,
                    trial=trial,
                    env_seed=trial,
                    radius=1.0,
                    truth=None,
                    mass_agent0=mass,
                    error_agent0=None,
                    plan_time=np.zeros(15),
                )
            )
    return records


def test_fig1_legends_name_every_mark(rng: np.random.Generator) -> None:
    bounds = {
        4: np.tile(np.linspace(0, 1, 16), (12, 1)),
        2: np.tile(np.linspace(0, 1, 16), (12, 1)),
    }
    figure = fig1_figure(_records(rng), "title", bounds)
    assert [axes.get_title()[:3] for axes in figure.get_axes()] == ["(a)", "(b)", "(c)"]
    assert unexplained_marks(figure) == []
    texts = _explanations(figure)
    assert IQR_LABEL in texts and SE_LABEL in texts
    # panel (a): bars only for the planners of the claim
    panel_a = figure.get_axes()[0]
    assert sum(artist.get_gid() == IQR_LABEL for artist in panel_a.collections) == 2
    assert small_texts(figure) == []


def test_a_mark_without_a_legend_entry_is_reported(rng: np.random.Generator) -> None:
    figure = fig1_figure(_records(rng))
    figure.get_axes()[0].plot([0, 1], [0, 1], gid="an unexplained curve")
    figure.get_axes()[1].scatter([0], [0])  # no gid at all
    assert len(unexplained_marks(figure)) == 2


def _row(setting: str, planner: str, n_agents: int, rng: np.random.Generator) -> GapRow:
    curve = np.concatenate([rng.uniform(0, 0.05, 20), np.zeros(41)])
    return GapRow(
        setting=setting,
        factor=setting,
        value="1",
        planner=planner,
        n_agents=n_agents,
        trials=100,
        mass_single=0.8,
        mass_gap=0.01,
        mass_gap_se=0.002,
        mass_p=1e-5,
        ttl_single=18.0,
        ttl_gap=0.5,
        ttl_gap_se=0.2,
        ttl_p=0.01,
        gap_curve=curve.tolist(),
        gap_curve_se=(0.1 * curve).tolist(),
    )


def test_ablation_figure_is_readable(rng: np.random.Generator) -> None:
    rows = [_row("defaults", "pairwise", n, rng) for n in (2, 4, 10)]
    rows += [_row("defaults", "infoseek.experiments.decisions:pairwise_first_step", 4, rng)]
    rows += [_row(f"sigma_{k}", "pairwise", 4, rng) for k in range(6)]
    figure = ablation_figure(rows)
    assert unexplained_marks(figure) == []
    heat = figure.get_axes()[1]
    assert len(heat.images) == 1 and heat.images[0].get_array().shape == (7, 61)
    assert len(heat.lines) == 0  # no pile of noisy curves
    assert small_texts(figure) == []
    titles = [axes.get_title() for axes in figure.get_axes() if axes.get_title()]
    assert len(titles) == 3


@pytest.mark.parametrize("env_id", ["bearings_v0", "beacon_v0"])
def test_search_frames_name_every_mark_with_and_without_the_zoom(
    env_id: str, rng: np.random.Generator
) -> None:
    env = infoseek.envs.make(env_id, n_agents=3, n_particles=300)
    renderer = SearchRenderer(env.unwrapped.config.space)
    space = env.unwrapped.config.space
    spread = rng.uniform(space.low, space.high, size=(500, space.dim))
    weights = np.full(500, 1.0 / 500)
    trails = np.stack([np.linspace([5, 5], [20 + a, 30], 10) for a in range(3)], axis=1)
    target = np.asarray(space.high) / 2
    common = {"trails": trails, "headings": np.ones((3, 2)) / np.sqrt(2), "radius": 1.0}
    renderer.draw(
        particles=spread, weights=weights, estimate=spread.mean(0), target=target, step=1, **common
    )
    assert renderer.inset is None
    assert unexplained_marks(renderer.figure) == []
    assert not any("zoom" in text for text in _explanations(renderer.figure))
    tight = spread.copy()
    tight[:, :2] = rng.normal([30.0, 8.0], 0.3, size=(500, 2))
    renderer.draw(
        particles=tight, weights=weights, estimate=tight.mean(0), target=target, step=2, **common
    )
    assert renderer.inset is not None and renderer.inset.get_visible()
    assert unexplained_marks(renderer.figure) == []
    texts = _explanations(renderer.figure)
    assert any("localisation radius" in text for text in texts)
    assert any("scale bar" in text for text in texts)
    bar_label = renderer._scale_bar.txt_label.get_text()
    assert bar_label.endswith(("unit", "units")) and float(bar_label.split()[0]) > 0
    # the zoom sits in the corner that hides no trail point
    x, y, w, h = renderer._corner
    x0, x1 = renderer.axes.get_xlim()
    y0, y1 = renderer.axes.get_ylim()
    fractions = (trails.reshape(-1, 2) - [x0, y0]) / [x1 - x0, y1 - y0]
    inside = (
        (fractions[:, 0] >= x)
        & (fractions[:, 0] <= x + w)
        & (fractions[:, 1] >= y)
        & (fractions[:, 1] <= y + h)
    )
    assert not inside.any()
    assert small_texts(renderer.figure) == []
    renderer.close()
    env.close()
