"""Predictions unfolding step by step, as an animated image per test window (stage `animations`;
the report's "Predictions, step by step", after the Y-net paper's animated figure).

A window is what the Y-net evaluations store for their qualitative figures (one `.npz` per
benchmark; keys `<name>_<i>` for window i = 0, 1, ...; coordinates in the scene image's pixels):
scene_image (H, W, 3) uint8, past (n_past, 2), future (n_future, 2), goal_heatmap (h, w) (stretched
over the image when h, w differ from H, W), sampled_goals (K_g, 2), predictions (K, n_future, 2) and
optionally scene_id () str. (trajectory_heatmap, also stored, is drawn by the static figure only.)

The storyboard, one frame each: the observed past drawing in point by point; the goal heatmap
fading in; the K_g sampled goals; then the K predicted futures and the ground truth extending one
step per frame (the heatmap dimmed so the paths read), the last frame held. A caption strip under
the scene names the benchmark, the scene and the phase, with a legend.

Drawn with Pillow rather than matplotlib: the scene images are small (about 90 x 120 px), so frames
are drawn at a fixed upscale, paths anti-aliased by supersampling, at about 10 ms a frame.

Written as animated WebP (lossy, quality 80, one key frame): about 150-180 kB a window of the
long-term benchmark, in full colour. The same frames as a GIF take 310-390 kB and its 256 colours
cannot hold the photo, the heatmap and the markers at once (the heatmap posterises into bands,
the marker colours drift); with dithering the GIF grows to 1.5 MB, as lossless WebP takes 1 MB and
APNG 3.5 MB. Chromium, Firefox and Safari play animated WebP. The encoder (libwebp, bundled with
Pillow) gives the same bytes for the same frames, so a re-run rewrites nothing.
"""

from __future__ import annotations

import io
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.io import IntermediateError

# What each stored array must look like: a letter names a size that must agree across arrays.
WINDOW_SHAPES = {
    "scene_image": ("H", "W", 3),
    "past": ("P", 2),
    "future": ("T", 2),
    "goal_heatmap": ("h", "w"),
    "sampled_goals": ("G", 2),
    "predictions": ("K", "T", 2),
}
# What the page and the captions call a benchmark label (`--qualitative <label>=<path>`), with
# the time one step stands for (long-term windows are sampled at 1 FPS, short-term at 2.5 FPS).
BENCHMARK_TITLES = {
    "long_term": f"{SDD_LONG_TERM.title}, 1 s a step",
    **{f"short_term_{d}": f"{b.title}, 0.4 s a step" for d, b in SHORT_TERM.items()},
}
LABEL = re.compile(r"[a-z0-9_]+")  # labels name files: <label>_<i>.webp

PAST = (31, 79, 255)  # blue, as in the static qualitative figure
TRUTH = (0, 200, 0)  # green
PREDICTED = (230, 0, 0)  # red
GOAL = (0, 230, 255)  # cyan: stands out on the heatmap's black-red-yellow
OUTLINE = (0, 0, 0)
CAPTION_BACKGROUND = (255, 255, 255)
CAPTION_TEXT = (20, 20, 20)


class AnimationInputError(IntermediateError):
    """A qualitative `.npz` that does not hold what the animation draws (the message names the file
    and the key)."""


@dataclass(frozen=True)
class Window:
    """One test window's arrays, coordinates (x, y) in `scene_image`'s pixels."""
    scene_image: np.ndarray  # (H, W, 3) uint8
    past: np.ndarray  # (n_past, 2)
    future: np.ndarray  # (n_future, 2)
    goal_heatmap: np.ndarray  # (h, w), any non-negative scale
    sampled_goals: np.ndarray  # (K_g, 2)
    predictions: np.ndarray  # (K, n_future, 2)
    scene_id: str


@dataclass(frozen=True)
class Storyboard:
    """How a window is animated: sizes in display pixels, durations in milliseconds."""
    long_side: int = 480  # the scene is scaled so its longer side has this many pixels
    supersample: int = 2  # paths are drawn this many times larger, then reduced (anti-aliasing)
    past_ms: int = 250  # per observed point
    fade_frames: int = 2  # the goal heatmap fades in over these frames
    fade_ms: int = 200
    goals_ms: int = 1500  # the sampled goals, before the futures start
    step_ms: int = 120  # per predicted step (about 8 frames a second)
    hold_ms: int = 3000  # the last frame, before the loop restarts
    heatmap_opacity: float = 0.85  # at the heatmap's peak, once faded in
    heatmap_opacity_paths: float = 0.45  # while the futures unfold
    heatmap_floor: float = 0.03  # values below this fraction of the peak are not drawn
    caption_height: int = 62  # three lines: benchmark and scene; the phase; the legend
    min_width: int = 360  # the legend's width: narrower scenes are centred on a wider frame
    font_size: int = 13

    def frame_count(self, n_past: int, n_future: int) -> int:
        return n_past + self.fade_frames + 1 + n_future


@dataclass(frozen=True)
class Frame:
    image: Image.Image  # RGB
    duration_ms: int


# ---------------------------------------------------------------------------------------------
# Reading


class ModelNotRun(Exception):
    """The `.npz` holds only the reason its model was not run (a short-term Y-net outside the
    profile's datasets writes `not_run_reason` alone)."""


NOT_RUN_KEY = "not_run_reason"


def read_windows(path: Path) -> list[Window]:
    """Every window of a qualitative `.npz`, checked against `WINDOW_SHAPES`; an
    `AnimationInputError` naming the file and the key otherwise, `ModelNotRun` with the reason
    for a file that says its model was not run."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except FileNotFoundError as e:
        raise AnimationInputError(f"{path}: missing") from e
    except (OSError, ValueError, EOFError) as e:
        raise AnimationInputError(f"{path}: not a readable npz archive ({e})") from e
    if set(arrays) == {NOT_RUN_KEY}:
        raise ModelNotRun(str(arrays[NOT_RUN_KEY]))
    indices = sorted({int(m[1]) for name in arrays
                      if (m := re.fullmatch(r"scene_image_(\d+)", name))})
    if not indices:
        raise AnimationInputError(f"{path}: no window (no key scene_image_<i>)")
    return [window_from_arrays(arrays, i, path) for i in indices]


def window_from_arrays(arrays: Mapping[str, np.ndarray], i: int, path: Path) -> Window:
    """Window `i` of `arrays` (keys `<name>_<i>`), its shapes checked against each other."""
    sizes: dict[str, int] = {}
    found = {}
    for name, shape in WINDOW_SHAPES.items():
        key = f"{name}_{i}"
        if key not in arrays:
            raise AnimationInputError(f"{path}: missing key {key}")
        array = arrays[key]
        want = "(" + ", ".join(str(s) for s in shape) + ")"
        if array.ndim != len(shape):
            raise AnimationInputError(f"{path}: {key} has shape {array.shape}, expected {want}")
        for axis, (size, expected) in enumerate(zip(array.shape, shape)):
            if isinstance(expected, int) and size != expected:
                raise AnimationInputError(f"{path}: {key} has shape {array.shape}, expected {want}")
            if isinstance(expected, str) and sizes.setdefault(expected, size) != size:
                raise AnimationInputError(f"{path}: {key} has shape {array.shape}, expected {want} "
                                          f"with {expected} = {sizes[expected]} as in the keys before")
            if size == 0:
                raise AnimationInputError(f"{path}: {key} is empty (axis {axis})")
        if name == "scene_image" and array.dtype != np.uint8:
            raise AnimationInputError(f"{path}: {key} has dtype {array.dtype}, expected uint8")
        if name != "scene_image" and not (array.dtype.kind == "f" and np.isfinite(array).all()):
            raise AnimationInputError(f"{path}: {key} must hold finite floats (dtype {array.dtype})")
        found[name] = array
    scene_id = arrays.get(f"scene_id_{i}")
    return Window(**found, scene_id=str(scene_id) if scene_id is not None else f"window {i}")


# ---------------------------------------------------------------------------------------------
# Drawing


def heatmap_rgba(heatmap: np.ndarray, size: tuple[int, int], floor: float) -> Image.Image:
    """The heatmap (h, w) stretched to `size` (W, H), coloured with inferno; its alpha grows with the
    value (1 at the peak), so the scene stays visible where the model puts no goal, and is 0 below
    `floor` x the peak (a fade then changes only the pixels of the heatmap's support)."""
    from matplotlib import colormaps  # only the colour map, no figure

    peak = float(heatmap.max())
    norm = np.clip(heatmap / peak, 0.0, 1.0) if peak > 0 else np.zeros_like(heatmap)
    small = Image.fromarray(norm.astype(np.float32), mode="F").resize(size, Image.Resampling.BILINEAR)
    norm = np.clip(np.asarray(small), 0.0, 1.0)  # (H, W)
    rgba = colormaps["inferno"](norm)  # (H, W, 4) floats
    # sqrt: the tails still show; shifted so the alpha rises from 0 at the floor, with no edge there
    rgba[..., 3] = np.clip((np.sqrt(norm) - np.sqrt(floor)) / (1 - np.sqrt(floor)), 0.0, 1.0)
    return Image.fromarray(np.round(rgba * 255).astype(np.uint8), mode="RGBA")


class Canvas:
    """One window's fixed parts (scaled scene, heatmap, fonts) and how to draw on them."""

    def __init__(self, window: Window, title: str, board: Storyboard):
        self.window, self.title, self.board = window, title, board
        h, w = window.scene_image.shape[:2]
        self.scale = board.long_side / max(h, w)
        self.size = (round(w * self.scale), round(h * self.scale))  # (W, H) on screen
        self.scene = Image.fromarray(window.scene_image).resize(self.size, Image.Resampling.LANCZOS)
        self.heat = heatmap_rgba(window.goal_heatmap, self.size, board.heatmap_floor)
        self.font = ImageFont.load_default(size=board.font_size)
        self.width = max(self.size[0], board.min_width)

    def heatmap(self, opacity: float) -> Image.Image:
        heat = self.heat.copy()
        heat.putalpha(heat.getchannel("A").point(lambda a: round(a * opacity)))
        return heat

    def xy(self, points: np.ndarray) -> list[tuple[float, float]]:
        """Stored pixel coordinates (n, 2) -> the supersampled layer's."""
        s = self.scale * self.board.supersample
        return [(float(x) * s, float(y) * s) for x, y in points]

    def paths_layer(self, past: int, goals: bool, steps: int) -> Image.Image:
        """Anti-aliased RGBA layer: `steps` steps of every prediction, the goals if `goals`, as many
        of the truth (each continuing from the last observed point), the first `past` observed
        points; later ones drawn over earlier ones."""
        ss = self.board.supersample
        layer = Image.new("RGBA", (self.size[0] * ss, self.size[1] * ss), (0, 0, 0, 0))
        draw = ImageDraw.Draw(layer)
        win = self.window
        start = win.past[-1:]
        if steps:
            for path in win.predictions:
                points = self.xy(np.concatenate([start, path[:steps]]))
                draw.line(points, fill=(*PREDICTED, 200), width=2 * ss, joint="curve")
                dot(draw, points[-1], 2.5 * ss, PREDICTED)
        if goals:  # over the predictions: a path that reaches its goal ends under the star
            for x, y in self.xy(win.sampled_goals):
                star(draw, x, y, 6 * ss)
        if steps:
            truth = self.xy(np.concatenate([start, win.future[:steps]]))
            draw.line(truth, fill=(*TRUTH, 255), width=4 * ss, joint="curve")
            dot(draw, truth[-1], 4 * ss, TRUTH)
        observed = self.xy(win.past[:past])
        if len(observed) > 1:
            draw.line(observed, fill=(*PAST, 255), width=4 * ss, joint="curve")
        for point in observed:
            dot(draw, point, 3 * ss, PAST)
        return layer.reduce(ss)  # box filter: each display pixel averages its ss x ss samples

    def frame(self, heat_opacity: float, past: int, goals: bool, steps: int, phase: str) -> Image.Image:
        picture = self.scene.convert("RGBA")
        if heat_opacity > 0:
            picture.alpha_composite(self.heatmap(heat_opacity))
        picture.alpha_composite(self.paths_layer(past, goals, steps))
        out = Image.new("RGB", (self.width, self.size[1] + self.board.caption_height), CAPTION_BACKGROUND)
        out.paste(picture.convert("RGB"), ((self.width - self.size[0]) // 2, 0))
        self.caption(ImageDraw.Draw(out), self.size[1], phase)
        return out

    def caption(self, draw: ImageDraw.ImageDraw, top: int, phase: str) -> None:
        """Three lines under the scene: benchmark and scene; the phase; the legend."""
        line = self.board.font_size + 5
        draw.text((6, top + 3), f"{self.title} | {self.window.scene_id}", font=self.font,
                  fill=CAPTION_TEXT)
        draw.text((6, top + 3 + line), phase, font=self.font, fill=CAPTION_TEXT)
        x, y = 6, top + 3 + 2 * line + line // 2
        for colour, label, marker in ((PAST, "past", "line"), (TRUTH, "truth", "line"),
                                      (PREDICTED, f"Y-net, {len(self.window.predictions)} paths",
                                       "line"), (GOAL, "sampled goals", "star")):
            if marker == "line":
                draw.line([(x, y), (x + 16, y)], fill=colour, width=3)
            else:
                star(draw, x + 8, y, 6)
            x += 20
            draw.text((x, y), label, font=self.font, fill=CAPTION_TEXT, anchor="lm")
            x += round(draw.textlength(label, font=self.font)) + 12


def dot(draw: ImageDraw.ImageDraw, centre: tuple[float, float], radius: float,
        colour: tuple[int, int, int]) -> None:
    x, y = centre
    draw.ellipse([x - radius, y - radius, x + radius, y + radius], fill=(*colour, 255),
                 outline=(*OUTLINE, 255), width=max(1, round(radius / 3)))


def star(draw: ImageDraw.ImageDraw, x: float, y: float, radius: float) -> None:
    """A five-pointed star (a goal), black-edged so it reads on any background."""
    angles = np.pi / 2 + np.arange(10) * np.pi / 5
    radii = np.where(np.arange(10) % 2 == 0, radius, radius * 0.45)
    points = [(x + r * np.cos(a), y - r * np.sin(a)) for r, a in zip(radii, angles)]
    draw.polygon(points, fill=(*GOAL, 255), outline=(*OUTLINE, 255), width=max(1, round(radius / 5)))


def frames(window: Window, title: str, board: Storyboard = Storyboard()) -> list[Frame]:
    """The storyboard's frames (`board.frame_count(n_past, n_future)` of them), in order."""
    canvas = Canvas(window, title, board)
    n_past, n_future = len(window.past), len(window.future)
    out = [Frame(canvas.frame(0.0, p, False, 0, f"observed past: point {p}/{n_past}"), board.past_ms)
           for p in range(1, n_past + 1)]
    for f in range(1, board.fade_frames + 1):
        opacity = board.heatmap_opacity * f / board.fade_frames
        out.append(Frame(canvas.frame(opacity, n_past, False, 0, "goal heatmap (U_g)"), board.fade_ms))
    out.append(Frame(canvas.frame(board.heatmap_opacity, n_past, True, 0,
                                  f"{len(window.sampled_goals)} sampled goals"), board.goals_ms))
    for t in range(1, n_future + 1):
        out.append(Frame(canvas.frame(board.heatmap_opacity_paths, n_past, True, t,
                                      f"predicted future: step {t}/{n_future}"), board.step_ms))
    out[-1] = Frame(out[-1].image, board.hold_ms)
    return out


WEBP_QUALITY = 80  # lossy; the thin paths stay sharp at 80, and each step above adds about 10 %


def webp_bytes(frames: list[Frame]) -> bytes:
    """The frames as a looping animated WebP. Only the first frame is a key frame (Pillow's default
    for lossy is one every 3-5 frames): the others store only what changed, which is what keeps
    a path-drawing frame at a few kB."""
    buffer = io.BytesIO()
    frames[0].image.save(buffer, format="WEBP", save_all=True,
                         append_images=[f.image for f in frames[1:]],
                         duration=[f.duration_ms for f in frames], loop=0, quality=WEBP_QUALITY,
                         method=4, kmin=0, kmax=0)
    return buffer.getvalue()


def animate(window: Window, title: str, board: Storyboard = Storyboard()) -> bytes:
    """One window's animated WebP."""
    return webp_bytes(frames(window, title, board))


def benchmark_title(label: str) -> str:
    return BENCHMARK_TITLES.get(label, label)


@dataclass(frozen=True)
class Rendered:
    """One benchmark's animations: the files to write (name -> bytes) and its entry in the
    index the report reads."""
    files: dict[str, bytes]
    entry: dict


def render_benchmark(label: str, path: Path, board: Storyboard = Storyboard()) -> Rendered:
    """Every window of the `.npz` at `path` animated as `<label>_<i>.webp`. A missing file gives
    an entry that says so and no file (a benchmark whose evaluation has not run); a malformed one
    raises `AnimationInputError`; one that says its model was not run gives an entry with the
    reason."""
    entry = {"benchmark": label, "title": benchmark_title(label), "source": Path(path).as_posix()}
    if not Path(path).exists():
        return Rendered({}, {**entry, "status": "missing", "windows": [],
                             "reason": f"{Path(path).as_posix()} missing (its evaluation has not run)"})
    try:
        read = read_windows(Path(path))
    except ModelNotRun as not_run:
        return Rendered({}, {**entry, "status": "not_run", "windows": [],
                             "reason": f"Y-net not run: {not_run}"})
    files, windows = {}, []
    for i, window in enumerate(read):
        name = f"{label}_{i}.webp"
        files[name] = animate(window, entry["title"], board)
        windows.append({"file": name, "scene_id": window.scene_id, "bytes": len(files[name]),
                        "frames": board.frame_count(len(window.past), len(window.future)),
                        "n_past": len(window.past), "n_future": len(window.future),
                        "k": len(window.predictions)})
    return Rendered(files, {**entry, "status": "shown", "windows": windows})
