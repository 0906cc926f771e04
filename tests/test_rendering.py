"""The rendered frame explains itself: every vehicle and trail inside the axes, one colour and a
heading arrow per vehicle, a legend, axis labels, the step and posterior mass in the title, a
zoom inset exactly when the belief has collapsed; ``infoseek demo`` writes what it has when
interrupted."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from PIL import Image

import infoseek.envs
import infoseek.experiments.demo as demo
from infoseek.envs.rendering import SearchRenderer, frame_title, particle_colours
from infoseek.experiments.cli import main

SMALL = {"n_particles": 300}


def _inside(renderer: SearchRenderer, points: np.ndarray) -> bool:
    x0, x1 = renderer.axes.get_xlim()
    y0, y1 = renderer.axes.get_ylim()
    return bool(
        np.all((points[:, 0] >= x0) & (points[:, 0] <= x1))
        and np.all((points[:, 1] >= y0) & (points[:, 1] <= y1))
    )


def _uniform_particles(rng: np.random.Generator, n: int = 500) -> tuple[np.ndarray, np.ndarray]:
    return rng.uniform(0.0, 40.0, size=(n, 2)), np.full(n, 1.0 / n)


def _draw(renderer: SearchRenderer, particles: np.ndarray, weights: np.ndarray, **kw: Any) -> Any:
    estimate = np.average(particles, weights=weights, axis=0)
    return renderer.draw(
        particles=particles,
        weights=weights,
        estimate=estimate,
        target=np.array([20.0, 20.0]),
        **kw,
    )


def test_axes_contain_vehicles_and_trails_that_leave_the_domain() -> None:
    env = infoseek.envs.make("bearings_v0", render_mode="rgb_array", n_agents=2, **SMALL)
    renderer = SearchRenderer(env.unwrapped.config.space)
    rng = np.random.default_rng(0)
    particles, weights = _uniform_particles(rng)
    # two vehicles flying straight out of the 40 x 40 box, to (-30, 20) and (75, 90)
    t = np.linspace(0.0, 1.0, 16)[:, None]
    trails = np.stack([(1 - t) * [5.0, 20.0] + t * [-30.0, 20.0], t * [75.0, 90.0]], axis=1)
    headings = np.array([[-1.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5)]])
    _draw(renderer, particles, weights, trails=trails, step=15, headings=headings)
    assert _inside(renderer, trails.reshape(-1, 2))
    assert _inside(renderer, np.array([[0.0, 0.0], [40.0, 40.0]]))  # the domain box too
    tips = renderer.arrows.get_offsets() + renderer.arrows.U[:, None] * [1, 0]
    assert _inside(renderer, np.asarray(tips))
    renderer.close()
    env.close()


def test_demo_episode_keeps_every_vehicle_on_screen() -> None:
    env = infoseek.envs.make("bearings_v0", render_mode="rgb_array", n_agents=4, **SMALL)
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    for _ in range(20):
        env.step({a: rng.uniform(-1.0, 1.0, size=1) for a in env.agents})
        env.render()
        positions = env.unwrapped.config.vehicle.position(env.unwrapped.vehicle_states)
        assert _inside(env.unwrapped.renderer, positions)
    env.close()


def test_legend_colours_headings_and_title() -> None:
    env = infoseek.envs.make("bearings_v0", render_mode="rgb_array", n_agents=4, **SMALL)
    _, infos = env.reset(seed=0)
    _, _, _, _, infos = env.step({a: np.zeros(1) for a in env.agents})
    env.render()
    renderer = env.unwrapped.renderer
    labels = [text.get_text() for text in renderer.legend.get_texts()]
    assert labels[:3] == ["particles (darker = heavier)", "MMSE estimate", "true target"]
    assert [label.split(" (")[0] for label in labels[3:]] == [f"vehicle {a}" for a in range(4)]
    colours = {to_rgba(line.get_color()) for line in renderer.trail_lines}
    assert len(colours) == 4  # one colour per vehicle
    assert renderer.axes.get_xlabel() and renderer.axes.get_ylabel()
    # the arrows point along each airplane's heading
    states = env.unwrapped.vehicle_states
    heading = states[:, list(env.unwrapped.config.vehicle.state_names).index("heading")]
    arrows = np.stack([renderer.arrows.U, renderer.arrows.V], axis=1)
    np.testing.assert_allclose(
        np.arctan2(arrows[:, 1], arrows[:, 0]), np.angle(np.exp(1j * heading))
    )
    title = renderer.title_artist.get_text()
    assert "t = 1" in title
    assert f"{infos['vehicle_0']['posterior_mass']:.2f}" in title
    env.close()


def test_inset_appears_exactly_when_the_belief_has_collapsed() -> None:
    env = infoseek.envs.make("bearings_v0", n_agents=1, **SMALL)
    renderer = SearchRenderer(env.unwrapped.config.space)
    rng = np.random.default_rng(2)
    particles, weights = _uniform_particles(rng)
    _draw(renderer, particles, weights, trails=None, step=0, radius=1.0)
    assert renderer.inset is None or not renderer.inset.get_visible()
    # 95 % of the weight within 1 unit of (10, 30), 5 % spread: collapsed
    tight = np.concatenate([rng.normal([10.0, 30.0], 0.3, size=(475, 2)), particles[:25]])
    tight_weights = np.full(500, 1.0 / 500)
    _draw(renderer, tight, tight_weights, trails=None, step=1, radius=1.0)
    assert renderer.inset is not None and renderer.inset.get_visible()
    x0, x1 = renderer.inset.get_xlim()
    assert x0 < 10.0 < x1 and x1 - x0 < 40.0 / 8.0
    # back to a spread belief: the inset hides again
    _draw(renderer, particles, weights, trails=None, step=2, radius=1.0)
    assert not renderer.inset.get_visible()
    renderer.close()
    env.close()


def _full_draw(renderer: SearchRenderer) -> np.ndarray:
    """The figure drawn whole by matplotlib (no kept background), as RGB pixels."""
    for artist in renderer.figure.findobj(lambda artist: artist.get_animated()):
        artist.set_animated(False)
    canvas = renderer.figure.canvas
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


@pytest.mark.parametrize("space", ["planar", "planar_with_orientation"])
def test_every_frame_equals_a_full_draw_of_the_figure(space: str) -> None:
    """Frames redraw only the changing artists over kept pixels: each equals the whole figure
    drawn again, while the belief collapses (the inset appears, moves corner and hides), the
    vehicles leave the domain (the limits grow) and stay (the pixels are reused)."""
    from infoseek.envs.targets import TargetSpace

    target_space = getattr(TargetSpace, space)()
    renderer = SearchRenderer(target_space)
    rng = np.random.default_rng(3)
    spread = np.column_stack([rng.uniform(0.0, 40.0, (400, 2)), rng.uniform(0.0, 6.0, 400)])
    t = np.linspace(0.0, 1.0, 12)[:, None]
    outward = np.stack([(1 - t) * [5.0, 20.0] + t * [-25.0, 20.0], t * [60.0, 30.0]], axis=1)
    canvas = renderer.figure.canvas
    whole = canvas.draw
    whole_draws = []

    def counted_draw() -> None:  # the renderer's whole-figure draws, counted
        whole_draws.append(1)
        whole()

    canvas.draw = counted_draw
    for step in range(12):
        centre = [30.0, 30.0] if step < 8 else [8.0, 35.0]  # the inset changes corner at 8
        tight = np.column_stack([rng.normal(centre, 0.2, (400, 2)), rng.uniform(0.0, 6.0, 400)])
        particles = (tight if 4 <= step < 10 else spread)[:, : target_space.dim]
        weights = rng.dirichlet(np.ones(400))
        trails = outward[: min(step, 6) + 1]  # out of the domain until step 6, then hovering
        headings = np.array([[-1.0, 0.0], [0.0, 1.0]])
        frame = _draw(
            renderer, particles, weights, trails=trails, step=step, headings=headings, radius=1.0
        )
        canvas.draw = whole
        np.testing.assert_array_equal(frame, _full_draw(renderer), err_msg=f"step {step}")
        canvas.draw = counted_draw
    assert renderer.inset is not None
    assert len(whole_draws) <= 7  # steps 7-11 (limits and legend unchanged) reuse the pixels
    renderer.close()


def test_interrupted_demo_writes_the_frames_so_far_and_exits_130(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real_make_policy = demo.make_policy

    def interrupting_policy(*args: Any, **kwargs: Any) -> Any:
        policy = real_make_policy(*args, **kwargs)
        calls = {"n": 0}
        act = policy.act

        def act_then_interrupt(observations: Any, infos: Any) -> Any:
            calls["n"] += 1
            if calls["n"] == 3:
                raise KeyboardInterrupt
            return act(observations, infos)

        policy.act = act_then_interrupt
        return policy

    monkeypatch.setattr(demo, "make_policy", interrupting_policy)
    code = main(["demo", "--steps", "10", "--particles", "200", "--out", str(tmp_path)])
    assert code == 130
    assert "interrupted after 2 step(s)" in capsys.readouterr().out
    (gif,) = tmp_path.glob("*.gif")
    with Image.open(gif) as image:
        assert image.n_frames == 3  # the reset frame and the two completed steps
    assert len(list(tmp_path.glob("*.png"))) == 1
    assert not list(tmp_path.glob(".*.tmp"))


def test_demo_gif_is_the_file_pil_writes_from_the_rgb_frames(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The demo reduces its frames to a palette on a worker thread as they come: the GIF it
    writes is byte for byte the one PIL writes from the rendered RGB frames."""
    rendered: list[np.ndarray] = []
    real_make_env = demo.make_env

    def recording_env(*args: Any, **kwargs: Any) -> Any:
        env = real_make_env(*args, **kwargs)
        render = env.render

        def render_and_record() -> Any:
            frame = render()
            rendered.append(frame.copy())
            return frame

        env.render = render_and_record
        return env

    monkeypatch.setattr(demo, "make_env", recording_env)
    argv = ["demo", "--steps", "4", "--particles", "200", "--fps", "5", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    (gif,) = tmp_path.glob("*.gif")
    images = [Image.fromarray(frame) for frame in rendered]
    expected = tmp_path / "expected.gif"
    images[0].save(
        expected, format="GIF", save_all=True, append_images=images[1:], duration=200, loop=0
    )
    assert len(rendered) == 5 and gif.read_bytes() == expected.read_bytes()
    (png,) = tmp_path.glob("demo-*.png")
    np.testing.assert_array_equal(np.asarray(Image.open(png).convert("RGB")), rendered[-1])


def test_demo_progress_bar_shows_the_time_left(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["demo", "--steps", "2", "--particles", "200", "--out", str(tmp_path)])
    assert code == 0
    assert "demo" not in capsys.readouterr().err  # no bar off a terminal
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    bar = demo.progress_bar(5, "demo", True, unit="step")
    bar.update(1)
    text = str(bar)
    bar.close()
    assert "1/5" in text and "step" in text and "<" in text  # elapsed<remaining: the ETA


def test_particle_colours_are_opaque_greys_darker_for_heavier_weights() -> None:
    colours = particle_colours(np.array([0.0, 0.25, 0.5]))
    np.testing.assert_allclose(colours[:, 0], [0.9, 0.45, 0.0])
    np.testing.assert_array_equal(colours[:, 0], colours[:, 1])
    np.testing.assert_array_equal(colours[:, 0], colours[:, 2])
    np.testing.assert_array_equal(colours[:, 3], 1.0)
    np.testing.assert_allclose(particle_colours(np.zeros(2))[:, :3], 0.9)
    assert particle_colours(np.zeros(0)).shape == (0, 4)


def test_frame_title_gives_the_step_and_the_posterior_mass() -> None:
    assert frame_title("", 3, None, None) == "t = 3"
    assert frame_title("bearings", 3, None, 1.0) == "bearings  t = 3"
    assert frame_title("", 7, 0.456, 1.5) == (
        "t = 7\nposterior mass within 1.5 of the estimate: 0.46"
    )
    assert frame_title("", 7, 0.456, None) == "t = 7\nposterior mass of the estimate: 0.46"
