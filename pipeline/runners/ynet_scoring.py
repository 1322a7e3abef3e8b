"""Y-net scoring: TTST and CWS sampling over seeded rounds, the one metric, and the evaluation
sequence of the long-term benchmarks (stages `evaluate_ynet`, `evaluate_ynet_horizon`,
`evaluate_short_term_ynet`, `evaluate_ind`).

`evaluation_sequence` is the main result (TTST + CWS over `eval.rounds` rounds), the Table 3/4
ablation (no TTST no CWS, CWS only, both) and the K_e x K_a grid behind the paper's K_a figure,
written once for SDD and inD. Every round is seeded (`eval.seed + round`), so a fixed checkpoint
gives bit-identical metrics (on one CPU; on CUDA up to float rounding). The main setting's paths
and goals of every round can be kept as scored (`kept`, a `pipeline.harness.predictions`
`PredictionRounds`) for the stored-predictions file. `qualitative_examples` draws a few windows'
heatmaps and samples in one npz layout (the long-term figure's `qualitative_arrays` and the
short-term windows of `pipeline.runners.short_term`). Runs on the model's device;
on CUDA the trajectory decoder runs in bfloat16 (goals, and so FDE, stay float32), TTST's
k-means in its sync-light mode (`kmeans_check_every`) over the goals of up to 64 windows of a scene
at once (`ttst_windows`), and a scene's predictions come to the host in one copy. The model's
settings come from its checkpoint (`load_model`), never from params.yaml.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import torch
from tqdm import tqdm

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.config.ynet import YnetSettings
from pipeline.data.labels import sdd_scene_image
from pipeline.data.window_table import WindowArrays
from pipeline.data.ynet_data import SceneWindows, group_by_scene, window_inputs
from pipeline.device import CPU, conv_layout, generator, module_device, use_bf16
from pipeline.harness.metrics import METRIC_KEYS, rounds_record, seeded_rounds, window_errors
from pipeline.harness.predictions import PredictionRounds
from pipeline.model_list import YNET
from ynet.heatmaps import distance_maps
from ynet.model import YNet, YNetConfig
from ynet.sampling import (Encoded, SamplingOptions, draw_goals, encode, encoder_features,
                           predict, predict_encoded)
from ynet.segmentation import PAD_CLASS

if TYPE_CHECKING:  # annotations only: no code of a stage that runs this (pipeline.code_graph)
    from pipeline.config.cws import CwsParams
    from pipeline.config.eval import EvalParams
    from pipeline.config.ttst import TtstParams


CUDA_KMEANS_CHECK_EVERY = 16
"""On CUDA, TTST's k-means asks the host whether it has converged every 16 iterations instead of
waiting for the GPU about twice per iteration. At most 15 iterations run past the stop (their
centres frozen, a few small kernels each) against one sync saved per iteration; 16 is the low end
of what pays, not a value tuned on a GPU."""


def kmeans_check_every(device: torch.device) -> int | None:
    """TTST's k-means mode on `device` (`ynet.sampling.kmeans`' `check_every`): None on the CPU,
    the exact mode every CPU number was scored with; `CUDA_KMEANS_CHECK_EVERY` on CUDA, the
    sync-light mode, whose draws differ from the CPU's but repeat with the seed."""
    return CUDA_KMEANS_CHECK_EVERY if device.type == "cuda" else None


def sampling_options(k_e: int, k_a: int, ttst: TtstParams, cws: CwsParams, use_ttst: bool,
                     use_cws: bool) -> SamplingOptions:
    return SamplingOptions(K_e=k_e, K_a=k_a, temperature=ttst.temperature,
                           rel_threshold=ttst.rel_threshold, use_ttst=use_ttst, use_cws=use_cws,
                           sigma_factor=cws.sigma_factor, ratio=cws.ratio, rot=cws.rot)


def load_model(path: Path, device: torch.device = CPU) -> tuple[YNet, YnetSettings]:
    """Weights saved by `train_ynet.train` (on any device), ready for inference on `device`."""
    saved = torch.load(path, weights_only=True, map_location="cpu")
    config = YNetConfig(**{k: tuple(v) if isinstance(v, list) else v
                           for k, v in saved["config"].items()})
    model = YNet(config)
    model.load_state_dict(saved["model"])
    model.eval()
    return conv_layout(model, device), YnetSettings.from_saved(saved["settings"])


def load_for_scoring(path: Path, test: WindowArrays, semantic_maps: dict[str, np.ndarray],
                     sizes: dict[str, tuple[int, int]], threads: int, device: torch.device = CPU
                     ) -> tuple[YNet, YnetSettings, list[SceneWindows]]:
    """The checkpoint at `path` ready to score `test`: the model on `device`, torch on `threads`
    threads (the scoring params': a training may have run on one thread beside another) and
    denormals flushed as training leaves them, and the windows grouped by scene at the model's
    resize."""
    model, settings = load_model(path, device)
    torch.set_num_threads(threads)
    torch.set_flush_denormal(True)
    return model, settings, group_by_scene(test, semantic_maps, sizes, settings.resize, device)


@dataclass(frozen=True)
class Sampling:
    """One seeded sampling of every test window: the options and the seed of its generator."""

    options: SamplingOptions
    seed: int


@dataclass(frozen=True)
class Sampled:
    """A `Sampling`'s predictions in original pixels, rows as in the arrays, and its own time
    (drawing goals and waypoints and the trajectory decoder; the shared encoding not included)."""

    paths: np.ndarray  # (N, K, n_f, 2)
    goals: np.ndarray  # (N, K, 2)
    weights: np.ndarray | None  # (N, K) `ynet.sampling.Prediction.weights`; None without TTST
    seconds: float


CUDA_TTST_WINDOWS = 64
"""On CUDA, TTST draws the goals of up to 64 windows of a scene at once (whole batches): one
k-means over all of them, so its few hundred small kernels a run are shared by 64 windows instead
of one batch's. Each batch of the group is then encoded again for its trajectory decoder (the
encoder is under 2 % of scoring's FLOPs), which keeps only the group's inputs and waypoint maps
in memory, not its features."""


def ttst_windows(device: torch.device, batch_size: int) -> int:
    """How many windows' goals are drawn at once (`predict_samplings`): one batch on the CPU (the
    `cpu` profile's draws, in their order); on CUDA as many whole batches as fit in
    `CUDA_TTST_WINDOWS` (at least one)."""
    if device.type != "cuda":
        return batch_size
    return max(1, CUDA_TTST_WINDOWS // batch_size) * batch_size


@dataclass(frozen=True)
class EncodedBatch:
    """One batch of a group of windows (`predict_samplings`), encoded: its inputs (to encode them
    again), its encoder features (None where the group holds several batches), its waypoint logits,
    where its agents stand in the model's input and which rows of the arrays it fills."""

    inputs: torch.Tensor  # (B, C + n_p, H, W)
    features: list[torch.Tensor] | None
    waypoint_logits: torch.Tensor  # (B, n_w, H, W)
    last_observed: torch.Tensor  # (B, 2) in the input's pixels
    origin: torch.Tensor  # (B, 2) the input's pixel [0, 0] in the scene map
    rows: np.ndarray  # (B,)

    def encoded(self, model: YNet) -> Encoded:
        """The batch's `Encoded`, its features computed again if they were dropped."""
        features = self.features if self.features is not None else encoder_features(model, self.inputs)
        return Encoded(features=features, waypoint_logits=self.waypoint_logits)


def encoded_batches(model: YNet, scene: SceneWindows, first: int, stop: int, settings: YnetSettings,
                    batch_size: int, crop: int, crop_lead_steps: float) -> list[EncodedBatch]:
    """Windows `first` to `stop` of `scene` in batches of `batch_size`, each encoded; with more
    than one batch, the encoder features are dropped (a group's would fill the memory)."""
    batches = []
    for start in range(first, stop, batch_size):
        end = min(start + batch_size, stop)
        past = scene.past[start:end]
        inputs, origin = window_inputs(scene.semantic, past, settings.max_distance, crop, PAD_CLASS,
                                       crop_lead_steps)  # origin (B, 2)
        encoded = encode(model, inputs)
        features = encoded.features if stop - first <= batch_size else None
        batches.append(EncodedBatch(inputs, features, encoded.waypoint_logits, past[:, -1] - origin,
                                    origin, scene.index[start:end]))
    return batches


def predict_samplings(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                      samplings: list[Sampling], params: EvalParams, n_windows: int, desc: str,
                      crop: int = 0, crop_lead_steps: float = 0.0) -> tuple[list[Sampled], float]:
    """Every sampling of `samplings` over all windows in one pass: each batch of windows is encoded
    once (`ynet.sampling.encode`, seed-independent) and then sampled once per sampling, each with
    its own generator consumed batch after batch as a pass of its own would (so the numbers are
    those of separate passes, bit for bit). Returns the `Sampled` of each, in order, and the
    seconds spent building inputs and encoding (shared by all).

    crop > 0 runs the model on a crop x crop window ahead of each agent instead of the whole map
    (`ynet_data.window_inputs`): short-term futures stay near the agent. Runs on the model's device
    (scenes are moved there). On CUDA the trajectory decoder runs in bfloat16, TTST's k-means
    checks for convergence on the host only every `CUDA_KMEANS_CHECK_EVERY` iterations, and the
    goals of up to `CUDA_TTST_WINDOWS` windows are drawn at once (`ttst_windows`; each batch is
    then encoded again for its trajectory decoder). The predictions stay on the device until a
    scene is done, then come to the host in one copy.
    """
    device = module_device(model)
    check_every = kmeans_check_every(device)
    group_size = ttst_windows(device, params.batch_size)
    draws = [generator(device, sampling.seed) for sampling in samplings]
    bf16 = use_bf16(device, params.bf16)
    n_future = scenes[0].future.shape[1]
    paths = [np.zeros((n_windows, s.options.K, n_future, 2)) for s in samplings]
    goals = [np.zeros((n_windows, s.options.K, 2)) for s in samplings]
    weights = [np.full((n_windows, s.options.K), np.nan) if s.options.use_ttst else None
               for s in samplings]
    seconds = [0.0] * len(samplings)
    shared_seconds = 0.0
    with tqdm(total=n_windows, desc=desc, leave=False, disable=None) as progress:
        for scene in scenes:
            scene = scene.to(device)  # a no-op for scenes grouped on the model's device
            kept = []  # (sampling, rows, trajectory, goals, weights): on the device until the scene ends
            for first in range(0, len(scene), group_size):
                began = time.perf_counter()
                batches = encoded_batches(model, scene, first, min(first + group_size, len(scene)),
                                          settings, params.batch_size, crop, crop_lead_steps)
                goal_logits = (batches[0].waypoint_logits[:, -1] if len(batches) == 1 else
                               torch.cat([b.waypoint_logits[:, -1] for b in batches]))  # (G, H, W)
                shared_seconds += time.perf_counter() - began
                drawn = []  # each sampling's goals (G, K_e, 2) and masses (G, K_e) or None
                for i, sampling in enumerate(samplings):
                    began = time.perf_counter()
                    with torch.inference_mode():
                        drawn.append(draw_goals(goal_logits, sampling.options, draws[i], check_every))
                    seconds[i] += time.perf_counter() - began
                at = 0
                for batch in batches:
                    began = time.perf_counter()
                    encoded = batch.encoded(model)
                    shared_seconds += time.perf_counter() - began
                    size = len(batch.rows)
                    for i, sampling in enumerate(samplings):
                        began = time.perf_counter()
                        batch_goals = tuple(None if part is None else part[at:at + size]
                                            for part in drawn[i])
                        out = predict_encoded(model, encoded, batch.last_observed, sampling.options,
                                              draws[i], settings.max_distance, params.chunk_size,
                                              bf16, check_every, batch_goals)
                        kept.append((i, batch.rows, out.trajectory + batch.origin[:, None, None],
                                     out.goals + batch.origin[:, None], out.weights))
                        seconds[i] += time.perf_counter() - began
                    at += size
                    progress.update(size)
            began = time.perf_counter()
            for i, rows, path, goal, weight in on_host(kept):
                paths[i][rows] = path / settings.resize
                goals[i][rows] = goal / settings.resize
                if weight is not None:
                    weights[i][rows] = weight
            shared_seconds += time.perf_counter() - began
    return [Sampled(*out) for out in zip(paths, goals, weights, seconds)], shared_seconds


def on_host(kept: list[tuple]) -> list[tuple]:
    """`kept` with its tensors as numpy arrays of their own dtypes, copied to the host in one piece
    per dtype (a GPU waits once, not once per tensor); other values as they are."""
    tensors = [value for entry in kept for value in entry if isinstance(value, torch.Tensor)]
    arrays = {}
    for dtype in dict.fromkeys(t.dtype for t in tensors):
        same = [t for t in tensors if t.dtype == dtype]
        flat = torch.cat([t.flatten() for t in same]).cpu().numpy()
        pieces = np.split(flat, np.cumsum([t.numel() for t in same])[:-1])
        arrays.update((id(t), piece.reshape(t.shape)) for t, piece in zip(same, pieces))
    return [tuple(arrays[id(value)] if isinstance(value, torch.Tensor) else value for value in entry)
            for entry in kept]


def predict_scenes(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                   options: SamplingOptions, seed: int, params: EvalParams,
                   n_windows: int, desc: str, crop: int = 0,
                   crop_lead_steps: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Paths (N, K, n_f, 2) and goals (N, K, 2) in original pixels of one seeded sampling
    (`predict_samplings` of one)."""
    (sampled,), _ = predict_samplings(model, scenes, settings, [Sampling(options, seed)], params,
                                      n_windows, desc, crop, crop_lead_steps)
    return sampled.paths, sampled.goals


def prediction_metadata(table: Path, options: SamplingOptions | None = None,
                        checkpoint: Path | None = None) -> dict:
    """What a stored long-term SDD Y-net predictions file records besides its seeds: the model, the
    benchmark of the window table scored, the unit and split, and, where it was scored, the
    sampling options (K = K_e x K_a) and the checkpoint."""
    metadata = SDD_LONG_TERM.prediction_metadata(YNET, table)
    if options is not None:
        metadata.update(k=options.K, k_e=options.K_e, k_a=options.K_a,
                        sampling=asdict(options), checkpoint=str(checkpoint))
    return metadata


def rounds_result(record: dict, options: SamplingOptions) -> dict:
    """The metrics layout of one sampling setting: a `rounds_record` with its K_e and K_a after the
    summary (where the metrics files have always had them)."""
    summary = {key: record[key] for key in METRIC_KEYS}
    return {**summary, "k_e": options.K_e, "k_a": options.K_a, "rounds": record["rounds"],
            "per_round": record["per_round"]}


@dataclass(frozen=True)
class Setting:
    """One scored setting: sampling options over `rounds` seeded rounds (seed `params.seed + r`)."""

    name: str
    options: SamplingOptions
    rounds: int


def setting_samplings(scored: list[Setting], seed: int) -> list[Sampling]:
    """Every round of every setting of `scored` as a `Sampling`, in order; round r seeded `seed + r`."""
    return [Sampling(setting.options, seed + r) for setting in scored for r in range(setting.rounds)]


def evaluate_settings(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                      scored: list[Setting], params: EvalParams, truth: np.ndarray, desc: str,
                      kept: PredictionRounds | None = None) -> tuple[dict[str, dict], dict[str, float]]:
    """Every setting of `scored` over its seeded rounds, all sampled in one pass over the windows
    (`predict_samplings`): ({name: `rounds_result`}, {name: seconds}), where a setting's seconds are
    the shared encoding plus its own sampling, what it would take alone. `kept` (for the windows of
    `truth`, in its order) receives the first setting's rounds, paths, goals (original pixels) and
    weights (TTST's goal masses, `ynet.sampling.goal_masses`) exactly as scored."""
    samplings = setting_samplings(scored, params.seed)
    sampled, shared_seconds = predict_samplings(model, scenes, settings, samplings, params,
                                                len(truth), f"{desc} ({len(samplings)} samplings)")
    results, seconds, first = {}, {}, 0
    for number, setting in enumerate(scored):
        rounds = sampled[first:first + setting.rounds]
        first += setting.rounds
        if number == 0 and kept is not None:
            for r, drawn in enumerate(rounds):
                kept.add(params.seed + r, drawn.paths, weights=drawn.weights, goals=drawn.goals)

        def score_round(seed: int, rounds=rounds):
            drawn = rounds[seed - params.seed]
            return window_errors(drawn.paths, truth, drawn.goals)

        results[setting.name] = rounds_result(seeded_rounds(score_round, setting.rounds, params.seed),
                                              setting.options)
        seconds[setting.name] = shared_seconds + sum(drawn.seconds for drawn in rounds)
    return results, seconds


def evaluate(model, scenes, settings, options, params, truth, rounds, desc,
             kept: PredictionRounds | None = None) -> dict:
    """`options` scored over seeded rounds (seed `params.seed + r`), in the `rounds_result` layout
    (`evaluate_settings` of one setting; `kept` receives its rounds)."""
    results, _ = evaluate_settings(model, scenes, settings, [Setting("scored", options, rounds)],
                                   params, truth, desc, kept)
    return results["scored"]


def in_scene_frame(heatmap: torch.Tensor, origin: tuple[int, int], height: int,
                   width: int) -> np.ndarray:
    """A heatmap (h, w) over the model's input, whose pixel [0, 0] lies at `origin` (x, y) of the
    scene map, as a float32 (height, width) array over the scene map: zero where the input did not
    reach (a crop), the padding beyond the map dropped."""
    out = np.zeros((height, width), np.float32)
    (x, y), (h, w) = origin, heatmap.shape
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, width), min(y + h, height)
    if x1 > x0 and y1 > y0:
        out[y0:y1, x0:x1] = heatmap[y0 - y:y1 - y, x0 - x:x1 - x].float().cpu().numpy()
    return out


@torch.inference_mode()
def qualitative(model: YNet, scene: SceneWindows, row: int, settings: YnetSettings,
                options: SamplingOptions, image: np.ndarray, seed: int, crop: int = 0,
                crop_lead_steps: float = 0.0) -> dict[str, np.ndarray]:
    """Heatmaps and samples of one window, in the resized scene image's pixels. `image` (H, W, 3)
    BGR is the scene at its original size; `crop` > 0 runs the model on the crop x crop window
    `predict_scenes` gives it (heatmaps zero outside it)."""
    device = module_device(model)
    scene = scene.to(device)
    height, width = scene.semantic.shape[-2:]
    past = scene.past[row:row + 1]
    inputs, origin = window_inputs(scene.semantic, past, settings.max_distance, crop, PAD_CLASS,
                                   crop_lead_steps)  # (1, C + n_p, H', W'), origin (1, 2)
    out = predict(model, inputs, past[:, -1] - origin, options, generator(device, seed),
                  settings.max_distance, check_every=kmeans_check_every(device))
    features = model.encode(inputs)
    goal_logits = model.predict_goals(features)[0, -1]
    first = out.waypoints[:, :1]  # (1, 1, n_w, 2) the first sample's goal and waypoints
    maps = distance_maps(first[0], *inputs.shape[-2:], settings.max_distance)
    trajectory_logits = model.predict_trajectory(features, maps)[0]  # (n_f, H', W')
    at = tuple(int(v) for v in origin[0].round().tolist())  # crop pixel [0, 0] in the scene map

    def scene_frame(heatmap: torch.Tensor) -> np.ndarray:
        return in_scene_frame(heatmap, at, height, width)

    return {
        "scene_image": cv2.cvtColor(cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA),
                                    cv2.COLOR_BGR2RGB),
        "past": past[0].cpu().numpy(), "future": scene.future[row].cpu().numpy(),
        "goal_heatmap": scene_frame(torch.sigmoid(goal_logits / options.temperature)),
        "sampled_goals": (out.goals[0] + origin).cpu().numpy(),
        "trajectory_heatmap": scene_frame(torch.sigmoid(trajectory_logits).amax(0)),
        "predictions": (out.trajectory[0] + origin).cpu().numpy(),
    }


def qualitative_examples(model: YNet, picks: list[tuple[SceneWindows, int, np.ndarray]],
                         settings: YnetSettings, options: SamplingOptions, seed: int,
                         crop: int = 0, crop_lead_steps: float = 0.0) -> dict[str, np.ndarray]:
    """`qualitative` of each (scene, row, original BGR scene image) of `picks` (i = 0, 1, ...),
    keyed `<name>_<i>`, plus `scene_id_<i>`: the layout of `data/ynet_predictions/qualitative.npz`,
    which the report draws (`pipeline.report.figures.load_qualitative`)."""
    arrays = {}
    for i, (scene, row, image) in enumerate(picks):
        for key, value in qualitative(model, scene, row, settings, options, image, seed, crop,
                                      crop_lead_steps).items():
            arrays[f"{key}_{i}"] = value
        arrays[f"scene_id_{i}"] = np.array(scene.scene_id)
    return arrays


def ka_grid(params: EvalParams) -> list[tuple[int, int]]:
    """The K_e x K_a grid's cells (K_e, K_a), K_a fastest."""
    return [(k_e, k_a) for k_e in params.ka_grid_k_e for k_a in params.ka_grid_k_a]


def sequence_settings(params: EvalParams, ttst: TtstParams, cws: CwsParams,
                      extras: bool = True) -> list[Setting]:
    """What `evaluation_sequence` samples, in its order: "main" (TTST + CWS at `k_e`, `k_a` over
    `rounds`); with `extras`, the ablation rows "none" and "cws" (`ablation_rounds` each, none at
    0) and every grid cell but the main setting's, "K_e=<k_e> K_a=<k_a>" (one round)."""
    def options(k_e: int, k_a: int, use_ttst: bool = True, use_cws: bool = True) -> SamplingOptions:
        return sampling_options(k_e, k_a, ttst, cws, use_ttst, use_cws)

    main = (params.k_e, params.k_a)
    scored = [Setting("main", options(*main), params.rounds)]
    if extras and params.ablation_rounds > 0:
        scored += [Setting("none", options(*main, False, False), params.ablation_rounds),
                   Setting("cws", options(*main, False, True), params.ablation_rounds)]
    if extras:
        scored += [Setting(f"K_e={k_e} K_a={k_a}", options(k_e, k_a), 1)
                   for k_e, k_a in ka_grid(params) if (k_e, k_a) != main]
    return scored


def evaluation_sequence(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                        params: EvalParams, ttst: TtstParams, cws: CwsParams, truth: np.ndarray,
                        label: str = "", extras: bool = True,
                        after_main: Callable[[dict], None] | None = None,
                        kept: PredictionRounds | None = None) -> dict:
    """The long-term evaluation: {"main", "main_seconds"[, "ablation"][, "ka_grid"], "eval_seconds"}.

    main: TTST + CWS at (`k_e`, `k_a`) over `params.rounds` rounds. With `extras`: the ablation
    (`ablation_rounds` rounds of no TTST no CWS and CWS only, beside the main result; skipped at 0
    rounds) and the K_e x K_a grid (one round per cell, seed `params.seed`; skipped when
    `ka_grid_k_e` is empty). The grid cell of the main setting is the main result's first round,
    taken from it rather than sampled again (same seed, same options: the same numbers).
    All settings are sampled in one pass over the windows, each window encoded once
    (`evaluate_settings`); `main_seconds` is what the main setting alone takes (encoding included).
    `label` prefixes the progress bar; `after_main(partial result)` runs once the main result is in.
    `kept` receives the main result's rounds, nothing of the ablation or the grid.
    """
    start = time.perf_counter()
    main = (params.k_e, params.k_a)
    scored = sequence_settings(params, ttst, cws, extras)
    grid = ka_grid(params) if extras else []
    results, seconds = evaluate_settings(model, scenes, settings, scored, params, truth,
                                         f"{label}TTST+CWS", kept)
    result = {"main": results["main"], "main_seconds": seconds["main"]}
    if after_main is not None:
        after_main(result)
    if "none" in results:  # sequence_settings sampled the ablation
        result["ablation"] = {"ttst_cws": result["main"], "none": results["none"],
                              "cws": results["cws"]}
    if grid:
        main_first_round = rounds_result(rounds_record(result["main"]["per_round"][:1]),
                                         scored[0].options)
        result["ka_grid"] = [main_first_round if cell == main else results[f"K_e={cell[0]} K_a={cell[1]}"]
                             for cell in grid]
    result["eval_seconds"] = time.perf_counter() - start
    return result


def qualitative_arrays(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                       params: EvalParams, ttst: TtstParams, cws: CwsParams,
                       sdd_root: Path) -> dict[str, np.ndarray]:
    """The qualitative figure's arrays: for each of `params.qualitative_scenes` (i = 0, 1, ...), its
    window that moves farthest, as `qualitative` draws it under the main sampling options
    (`qualitative_examples`)."""
    options = sampling_options(params.k_e, params.k_a, ttst, cws, True, True)
    by_id = {s.scene_id: s for s in scenes}
    picks = []
    for scene_id in params.qualitative_scenes:
        scene = by_id[scene_id]
        row = int(torch.linalg.norm(scene.future[:, -1] - scene.past[:, -1], dim=-1).argmax())
        picks.append((scene, row, sdd_scene_image(sdd_root, scene_id)))
    return qualitative_examples(model, picks, settings, options, params.seed)
