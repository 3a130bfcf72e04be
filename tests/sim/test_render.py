"""Rendering: PettingZoo's render test, frames that show what the state says (robots by role,
inverted robots hollow, losses by cause, the map), blitting without ghosts, and GIF animations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from pettingzoo.test import render_test
from PIL import Image
from tiny_missions import TINY

import swarm.sim
from swarm.errors import InputError, SwarmError
from swarm.mission import load_mission
from swarm.report.style import ROLE_COLOURS, TERRAIN_COLOURS
from swarm.sim.layout import ROLES
from swarm.sim.render import (
    CAUSE_COLOURS,
    FRAME_WIDTH_PX,
    LINKS_PER_NODE,
    MAX_LINKS_DRAWN,
    MAX_MAP_HEIGHT_PX,
    Animator,
    check_animation_path,
    frame_layout,
    frame_stride,
    sparse_links,
)
from swarm.sim.run import simulate


@pytest.fixture(scope="module")
def tiny_path(tmp_path_factory) -> Path:
    """A 4-robot mission on the 120 m x 80 m test beach that ends after 270 s (540 steps)."""
    path = tmp_path_factory.mktemp("mission") / "tiny.yaml"
    path.write_text(TINY)
    return path


@pytest.mark.slow
def test_pettingzoo_render_test_passes(tiny_path):
    render_test(lambda render_mode=None: swarm.sim.env(mission=str(tiny_path), render_mode=render_mode))


def test_frame_layout_is_fixed_width_even_height_and_keeps_the_aspect():
    for w, h in ((120.0, 80.0), (1000.0, 200.0), (100.0, 900.0), (333.0, 111.0)):
        width, height, (left, bottom, aw, ah) = frame_layout(w, h)
        assert width == FRAME_WIDTH_PX and height % 2 == 0
        assert aw * width / (ah * height) == pytest.approx(w / h, rel=1e-9)
        assert ah * height <= MAX_MAP_HEIGHT_PX + 1e-9
        assert left >= 0 and left + aw <= 1 and bottom >= 0 and bottom + ah <= 1


@pytest.fixture
def env(tiny_path):
    e = swarm.sim.parallel_env(mission=str(tiny_path), render_mode="rgb_array")
    e.reset(seed=0)
    yield e
    e.close()


def _pixel(env, x: float, y: float) -> tuple[int, int]:
    """(row, col) of map point (x, y) in the frame."""
    r = env._renderer
    dx, dy = r.ax.transData.transform((x, y))
    return round(r.height - dy), round(dx)


def _near(frame: np.ndarray, row: int, col: int, colour: str, radius: int = 6, tol: int = 30) -> int:
    """Pixels within `radius` of (row, col) whose colour is within `tol` of `colour` per channel."""
    want = np.array([round(255 * c) for c in to_rgb(colour)])
    patch = frame[max(row - radius, 0) : row + radius + 1, max(col - radius, 0) : col + radius + 1].astype(
        int
    )
    return int((np.abs(patch - want).max(axis=-1) <= tol).sum())


def _hand_set(env) -> None:
    """Robot 0 a landing robot ashore at (60, 20); robot 1 lost to a mine at (90, 22); robot 2 an
    inverted search robot at (30, 24); nobody else on the map."""
    env.on_map[:] = False
    env.alive[:] = True
    env.role[0], env.role[2] = ROLES.index("landing"), ROLES.index("search")
    env.on_map[[0, 2]] = True
    env.robot_state[0, :2] = (60.0, 20.0)
    env.robot_state[2, :2] = (30.0, 24.0)
    env.inverted[2] = True
    env.alive[1] = False
    env.end_reason[1] = "mine"
    env.lost_at[1] = (100.0, 90.0, 22.0)


def test_frame_shows_the_state(env):
    before = env.render()  # nothing on the map yet
    _hand_set(env)
    frame = env.render()
    width, height, _ = frame_layout(env.beach.width_m, env.beach.height_m)
    assert frame.shape == (height, width, 3) and frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 50  # a map, not a blank canvas

    # the lost robot: its cause's colour at the loss, where it was not before
    row, col = _pixel(env, 90.0, 22.0)
    assert _near(frame, row, col, CAUSE_COLOURS["mine"]) >= 4
    assert _near(before, row, col, CAUSE_COLOURS["mine"]) == 0
    # the landing robot in its role's colour
    row, col = _pixel(env, 60.0, 20.0)
    assert _near(frame, row, col, ROLE_COLOURS["landing"], radius=3) >= 4
    assert _near(before, row, col, ROLE_COLOURS["landing"], radius=3) == 0
    # the inverted robot: hollow (white centre) with a ring in its role's colour
    row, col = _pixel(env, 30.0, 24.0)
    assert _near(frame, row, col, "#FFFFFF", radius=0, tol=40) == 1
    assert _near(frame, row, col, ROLE_COLOURS["search"], radius=5) >= 4
    # the map underneath: deep water in the south-west corner, soft sand inland
    row, col = _pixel(env, 5.0, 3.0)
    assert _near(frame, row, col, TERRAIN_COLOURS["deep_water"], radius=1, tol=3) == 9
    # the header says something: dark text pixels above the map
    assert (frame[:30].max(axis=-1) < 100).sum() > 100


def test_frames_have_no_ghosts(env):
    """Blitting restores the map each frame: a robot that moved leaves nothing behind, and the same
    state gives the same pixels."""
    _hand_set(env)
    first = env.render()
    assert np.array_equal(first, env.render())
    env.robot_state[0, :2] = (100.0, 60.0)
    moved = env.render()
    row, col = _pixel(env, 60.0, 20.0)
    assert _near(moved, row, col, ROLE_COLOURS["landing"], radius=3) == 0
    row, col = _pixel(env, 100.0, 60.0)
    assert _near(moved, row, col, ROLE_COLOURS["landing"], radius=3) >= 4
    # a second cause of loss rewrites the legend; taking it back restores the very same pixels
    env.alive[3], env.end_reason[3], env.lost_at[3] = False, "battery", (1.0, 50.0, 60.0)
    two = env.render()
    assert not np.array_equal(two[-25:], moved[-25:])  # the legend strip changed
    env.alive[3], env.end_reason[3], env.lost_at[3] = True, None, np.nan
    assert np.array_equal(env.render(), moved)


def test_a_new_episode_gets_a_fresh_map(env):
    """Tracks are painted into the kept bitmap; after a reset the frame starts from the bare map."""
    bare = env.render()
    env.tracks.append(np.tile(np.array([[10.0, 50.0]], np.float32), (env.n, 1)))
    env.tracks.append(np.tile(np.array([[110.0, 50.0]], np.float32), (env.n, 1)))
    with_track = env.render()
    row, _ = _pixel(env, 60.0, 50.0)
    changed = np.any(with_track != bare, axis=-1)
    assert changed[row - 2 : row + 3].sum() > 500  # a line across the map at y = 50 m
    env.reset(seed=0)
    fresh = env.render()
    other = swarm.sim.parallel_env(mission=env.mission.source, render_mode="rgb_array")
    other.reset(seed=0)
    assert np.array_equal(fresh, other.render())
    assert np.array_equal(fresh, bare)
    other.close()


def test_human_mode_without_a_display_returns_none_and_opens_nothing(tiny_path):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    e = swarm.sim.parallel_env(mission=str(tiny_path), render_mode="human")
    e.reset(seed=0)
    assert e.render() is None
    e.step({a: e.action_space(a).sample() for a in e.agents})  # human mode renders every step
    assert plt.get_fignums() == before
    e.close()


def test_human_mode_with_a_display_updates_one_window(tiny_path, monkeypatch):
    """With an interactive backend (faked here): one window, updated in place, a non-blocking
    pause per frame, and nothing more once the user closes it."""
    import matplotlib.pyplot as plt

    import swarm.sim.render as render

    pauses = []
    monkeypatch.setattr(render, "_interactive_backend", lambda: True)
    monkeypatch.setattr(plt, "pause", pauses.append)
    monkeypatch.setattr(plt, "show", lambda block=None: None)
    e = swarm.sim.parallel_env(mission=str(tiny_path), render_mode="human")
    e.reset(seed=0)
    e.render()
    e.step({a: e.action_space(a).sample() for a in e.agents})
    fig, image = e._renderer._window
    assert len(pauses) == 2 and pauses[0] == pytest.approx(1.0 / e.metadata["render_fps"])
    assert np.array_equal(np.asarray(image.get_array()), e._renderer.frame())
    plt.close(fig)  # the user closes the window
    e.render()
    assert len(pauses) == 2 and e._renderer._window is None
    e.close()


def test_sparse_links_keep_the_components_and_each_nodes_nearest():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(4)
    nodes = np.vstack([rng.uniform((0, 0), (300, 60), (150, 2)), rng.uniform((600, 0), (900, 60), (50, 2))])
    d = np.hypot(*(nodes[:, None] - nodes[None]).transpose(2, 0, 1))
    a, b = np.nonzero(np.triu(d < 80.0, 1))
    assert len(a) > MAX_LINKS_DRAWN
    sa, sb = sparse_links(a, b, nodes)
    assert len(sa) <= len(nodes) - 1 + LINKS_PER_NODE * len(nodes) < len(a) / 2
    real = set(zip(a.tolist(), b.tolist(), strict=True))
    assert set(zip(sa.tolist(), sb.tolist(), strict=True)) <= real

    def components(x, y):
        g = coo_matrix((np.ones(len(x)), (x, y)), shape=(len(nodes), len(nodes)))
        return connected_components(g, directed=False)[1]

    assert np.array_equal(components(sa, sb), components(a, b))
    # every node keeps its shortest link
    for i in rng.choice(len(nodes), 20, replace=False):
        mine = np.flatnonzero((a == i) | (b == i))
        if len(mine):
            k = mine[np.argmin(d[a[mine], b[mine]])]
            assert (a[k], b[k]) in set(zip(sa.tolist(), sb.tolist(), strict=True))


def test_frame_stride_gives_a_bounded_animation():
    # a 2-hour mission at 0.5 s steps: 360 frames, one every 20 s of mission
    assert frame_stride(14400, 0.5) == 40
    assert 14400 // frame_stride(14400, 0.5) <= 600
    # a short one: at least 5 s of mission a frame
    assert frame_stride(540, 0.5) == 10
    assert frame_stride(1, 0.5) == 10


@pytest.mark.slow
def test_gif_animation_of_a_run(tiny_path, tmp_path):
    out = tmp_path / "run.gif"
    visited: list[int] = []

    with Animator(out) as anim:

        def on_step(env) -> None:
            visited.append(env.steps)
            anim.on_step(env)

        log = simulate(load_mission(tiny_path), seed=1, on_step=on_step)
    assert visited[-1] == round(float(log.times_s[-1]) / 0.5)
    # every 10th step (5 s) the run went through (it strides over the swim in), and the last step
    expected = sum(1 for s in visited if s % 10 == 0) + (visited[-1] % 10 != 0)
    assert anim.frames == expected
    with Image.open(out) as gif:
        assert gif.n_frames == anim.frames > 1
        assert gif.size[0] == FRAME_WIDTH_PX
        gif.seek(gif.n_frames - 1)
        last = np.asarray(gif.convert("RGB"))
    assert len(np.unique(last.reshape(-1, 3), axis=0)) > 20
    assert [p.name for p in tmp_path.iterdir()] == ["run.gif"]  # no temporary file left


def test_failed_run_leaves_no_animation(tiny_path, tmp_path):
    calls = []

    def boom(env):
        anim.on_step(env)
        calls.append(1)
        if len(calls) == 25:
            raise SwarmError("stop")

    with pytest.raises(SwarmError), Animator(tmp_path / "run.gif") as anim:
        simulate(load_mission(tiny_path), seed=1, on_step=boom)
    assert list(tmp_path.iterdir()) == []


def test_animation_path_checks(tmp_path, monkeypatch):
    from matplotlib.animation import FFMpegWriter

    with pytest.raises(InputError, match=r"\.gif or \.mp4"):
        check_animation_path(tmp_path / "a.avi")
    with pytest.raises(InputError, match="existing folder"):
        check_animation_path(tmp_path / "missing" / "a.gif")
    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.raises(InputError, match="install ffmpeg"):
        check_animation_path(tmp_path / "a.mp4")
    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: True))
    assert check_animation_path(tmp_path / "a.MP4").name == "a.MP4"
    assert check_animation_path(tmp_path / "a.gif").name == "a.gif"


@pytest.mark.slow
def test_mp4_animation_or_a_clear_error(tiny_path, tmp_path):
    """With ffmpeg an H.264 MP4 (an ISO media file), without it a one-line InputError up front."""
    from matplotlib.animation import FFMpegWriter

    out = tmp_path / "run.mp4"
    if not FFMpegWriter.isAvailable():
        with pytest.raises(InputError, match="ffmpeg"):
            Animator(out)
        return
    with Animator(out, target_frames=10) as anim:
        simulate(load_mission(tiny_path), seed=1, on_step=anim.on_step)
    data = out.read_bytes()
    assert data[4:8] == b"ftyp" and len(data) > 10_000
    assert anim.frames > 1
    assert [p.name for p in tmp_path.iterdir()] == ["run.mp4"]
