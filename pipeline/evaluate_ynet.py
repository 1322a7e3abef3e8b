"""Stage `evaluate_ynet`: Y-net on the test windows with TTST and CWS, over several seeded rounds.

Separate from training, so `dvc exp run -S ttst.temperature=...` re-runs only this and the report.
Writes ADE / FDE in original pixels as mean and spread over `eval.rounds` rounds, with the paper's
independent minima and the joint ones; the Table 3 ablation (no TTST no CWS, CWS only, both); the
K_e x K_a grid behind the paper's K_a figure; and three windows' heatmaps for the qualitative figure.
Every round is seeded (`eval.seed + round`), so a fixed checkpoint gives bit-identical metrics
(on one CPU; on CUDA up to float rounding). Runs on `runtime.device`; on CUDA the trajectory decoder
runs in bfloat16 (goals, and so FDE, stay float32).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import torch
from tqdm import tqdm

from pipeline.device import (CPU, RuntimeParams, conv_layout, describe, generator, module_device,
                             select_device)
from pipeline.metrics import window_errors
from pipeline.params import load_profile, load_section, read_params
from pipeline.semantic_maps import load_semantic_maps
from pipeline.train_ynet import YnetSettings, image_sizes
from pipeline.window_table import to_arrays
from pipeline.ynet_data import (SceneWindows, group_by_scene, model_input, padded_semantic,
                                window_inputs)
from ynet.heatmaps import distance_maps
from ynet.model import YNet, YNetConfig
from ynet.sampling import SamplingOptions, predict
from ynet.segmentation import PAD_CLASS


@dataclass
class TtstParams:
    temperature: float = 1.8
    """Goal and waypoint maps are sigmoid(logits / temperature) before sampling."""
    rel_threshold: float = 0.002
    """Pixels below rel_threshold * max are never sampled."""


@dataclass
class CwsParams:
    sigma_factor: float = 6.0
    """Prior sigma = (distance + 5) / sigma_factor."""
    ratio: float = 2.0
    """Prior sigma across the direction of travel is divided by this."""
    rot: bool = True
    """Rotate the prior to the direction of travel."""


@dataclass
class EvalParams:
    k_e: int = 20
    """Goals per window for the main result."""
    k_a: int = 1
    """Paths per goal for the main result."""
    rounds: int = 3
    """Seeded evaluation rounds of the main result; mean and spread are reported."""
    ablation_rounds: int = 1
    """Rounds of each Table 3 ablation row (0 = skip the ablation)."""
    ka_grid_k_e: list[int] = field(default_factory=lambda: [20])
    """K_e values of the K_a figure's grid (empty = skip the grid)."""
    ka_grid_k_a: list[int] = field(default_factory=lambda: [1, 2, 5])
    """K_a values of the K_a figure's grid."""
    seed: int = 0
    """Round r uses seed + r."""
    batch_size: int = 4
    """Windows per forward pass (one scene per batch)."""
    chunk_size: int = 4
    """Samples per window decoded together by the trajectory decoder."""
    bf16: bool = False
    """bfloat16 autocast for the convolutions (faster on CPUs with AMX; positions change slightly)."""
    qualitative_scenes: list[str] = field(default_factory=lambda: ["hyang_0", "little_2", "nexus_6"])
    """Test scenes whose longest-moving window is drawn in the qualitative figure."""

    def __post_init__(self):
        if min(self.k_e, self.k_a, self.rounds, self.batch_size, self.chunk_size) < 1:
            raise ValueError("k_e, k_a, rounds, batch_size and chunk_size must be positive")


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
    return conv_layout(model, device), YnetSettings(**saved["settings"])



def predict_scenes(model: YNet, scenes: list[SceneWindows], settings: YnetSettings,
                   options: SamplingOptions, seed: int, params: EvalParams,
                   n_windows: int, desc: str, crop: int = 0,
                   crop_lead_steps: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Paths (N, K, n_f, 2) and goals (N, K, 2) in original pixels, rows as in the arrays.

    crop > 0 runs the model on a crop x crop window ahead of each agent instead of the whole map
    (`ynet_data.window_inputs`): short-term futures stay near the agent. Runs on the model's device
    (scenes are moved there); on CUDA the trajectory decoder runs in bfloat16.
    """
    device = module_device(model)
    draws = generator(device, seed)
    bf16 = params.bf16 or device.type == "cuda"
    n_future = scenes[0].future.shape[1]
    paths = np.zeros((n_windows, options.K, n_future, 2))
    goals = np.zeros((n_windows, options.K, 2))
    with tqdm(total=n_windows, desc=desc, leave=False, disable=None) as progress:
        for scene in scenes:
            scene = scene.to(device)  # a no-op for scenes grouped on the model's device
            for start in range(0, len(scene), params.batch_size):
                past = scene.past[start:start + params.batch_size]
                inputs, origin = window_inputs(scene.semantic, past, settings.max_distance,
                                               crop, PAD_CLASS, crop_lead_steps)  # origin (B, 2)
                out = predict(model, inputs, past[:, -1] - origin, options, draws,
                              settings.max_distance, params.chunk_size, bf16)
                rows = scene.index[start:start + params.batch_size]
                paths[rows] = (out.trajectory + origin[:, None, None]).cpu().numpy() / settings.resize
                goals[rows] = (out.goals + origin[:, None]).cpu().numpy() / settings.resize
                progress.update(len(rows))
    return paths, goals


def summarize_rounds(rounds: list[dict[str, float]]) -> dict[str, dict[str, float]]:
    """{metric: {mean, std, min, max}} over rounds (std = 0 for one round)."""
    result = {}
    for key in ("ade", "fde", "ade_joint", "fde_joint"):
        values = np.array([r[key] for r in rounds])
        result[key] = {"mean": float(values.mean()), "std": float(values.std()),
                       "min": float(values.min()), "max": float(values.max())}
    return result


def evaluate(model, scenes, settings, options, params, truth, rounds, desc) -> dict:
    scores = []
    for r in range(rounds):
        paths, goals = predict_scenes(model, scenes, settings, options, params.seed + r, params,
                                      len(truth), f"{desc} round {r + 1}/{rounds}")
        errors = window_errors(paths, truth, goals)
        scores.append({"ade": float(errors.ade.mean()), "fde": float(errors.fde.mean()),
                       "ade_joint": float(errors.ade.mean()),
                       "fde_joint": float(errors.fde_joint.mean())})
    return {**summarize_rounds(scores), "k_e": options.K_e, "k_a": options.K_a, "rounds": rounds,
            "per_round": scores}


@torch.inference_mode()
def qualitative(model: YNet, scene: SceneWindows, row: int, settings: YnetSettings,
                options: SamplingOptions, image: np.ndarray, seed: int) -> dict[str, np.ndarray]:
    """Heatmaps and samples of one window, in the resized scene image's pixels."""
    device = module_device(model)
    scene = scene.to(device)
    semantic = padded_semantic(scene.semantic, PAD_CLASS)
    height, width = scene.semantic.shape[-2:]
    past = scene.past[row:row + 1]
    inputs = model_input(semantic, past, settings.max_distance)
    out = predict(model, inputs, past[:, -1], options, generator(device, seed),
                  settings.max_distance)
    features = model.encode(inputs)
    goal_logits = model.predict_goals(features)[0, -1]
    first = out.waypoints[:, :1]  # (1, 1, n_w, 2) the first sample's goal and waypoints
    maps = distance_maps(first[0], *semantic.shape[-2:], settings.max_distance)
    trajectory_logits = model.predict_trajectory(features, maps)[0]  # (n_f, H, W)
    return {
        "scene_image": cv2.cvtColor(cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA),
                                    cv2.COLOR_BGR2RGB),
        "past": past[0].cpu().numpy(), "future": scene.future[row].cpu().numpy(),
        "goal_heatmap": torch.sigmoid(goal_logits / options.temperature)[:height, :width].cpu().numpy(),
        "sampled_goals": out.goals[0].cpu().numpy(),
        "trajectory_heatmap": torch.sigmoid(trajectory_logits).amax(0)[:height, :width].cpu().numpy(),
        "predictions": out.trajectory[0].cpu().numpy(),
    }


def write_json(payload: dict, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(payload, indent=2) + "\n")
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=Path, required=True)
    parser.add_argument("--model", type=Path, required=True)
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True)
    parser.add_argument("--n-past", type=int, default=5)
    parser.add_argument("--metrics", type=Path, required=True)
    parser.add_argument("--qualitative", type=Path, help="npz for the report's qualitative figure")
    parser.add_argument("--main-only", action="store_true", help="skip the ablation and K_a grid")
    args = parser.parse_args(argv)
    params = read_params()
    ttst = load_section(TtstParams, "ttst", params)
    cws = load_section(CwsParams, "cws", params)
    eval_params = load_profile(EvalParams, "eval", params)
    device = select_device(load_section(RuntimeParams, "runtime", params).device)

    model, settings = load_model(args.model, device)
    torch.set_num_threads(settings.threads)
    print(f"evaluate_ynet: on {describe(device)}")
    torch.set_flush_denormal(True)
    table = pd.read_parquet(args.windows)
    test = to_arrays(table[table["split"] == "test"], args.n_past)
    sizes = image_sizes(args.sdd, set(test.scene_id))
    scenes = group_by_scene(test, load_semantic_maps(args.semantic_maps), sizes, settings.resize,
                            device)

    start = time.perf_counter()
    main_options = sampling_options(eval_params.k_e, eval_params.k_a, ttst, cws, True, True)
    result = {"profile": params["profile"], "t_f": int(test.future.shape[1]),
              "n_windows": len(test), "rounds": eval_params.rounds,
              "main": evaluate(model, scenes, settings, main_options, eval_params, test.future,
                               eval_params.rounds, "TTST+CWS")}
    result["main_seconds"] = time.perf_counter() - start
    result["seconds_per_window"] = result["main_seconds"] / (len(test) * eval_params.rounds)
    print(f"evaluate_ynet: ADE {result['main']['ade']['mean']:.2f} ± {result['main']['ade']['std']:.2f}"
          f"  FDE {result['main']['fde']['mean']:.2f} ± {result['main']['fde']['std']:.2f}"
          f"  ({result['main_seconds']:.0f} s)")

    if not args.main_only and eval_params.ablation_rounds:
        result["ablation"] = {"ttst_cws": result["main"]}
        for name, use_ttst, use_cws in (("none", False, False), ("cws", False, True)):
            options = sampling_options(eval_params.k_e, eval_params.k_a, ttst, cws, use_ttst, use_cws)
            result["ablation"][name] = evaluate(model, scenes, settings, options, eval_params,
                                                test.future, eval_params.ablation_rounds, name)
    if not args.main_only and eval_params.ka_grid_k_e:
        result["ka_grid"] = []
        for k_e in eval_params.ka_grid_k_e:
            for k_a in eval_params.ka_grid_k_a:
                options = sampling_options(k_e, k_a, ttst, cws, True, True)
                scores = evaluate(model, scenes, settings, options, eval_params, test.future, 1,
                                  f"K_e={k_e} K_a={k_a}")
                result["ka_grid"].append(scores)
    result["eval_seconds"] = time.perf_counter() - start
    write_json(result, args.metrics)

    if args.qualitative:
        arrays = {}
        by_id = {s.scene_id: s for s in scenes}
        for i, scene_id in enumerate(eval_params.qualitative_scenes):
            scene = by_id[scene_id]
            row = int(torch.linalg.norm(scene.future[:, -1] - scene.past[:, -1], dim=-1).argmax())
            scene_name, video = scene_id.rsplit("_", 1)
            image = cv2.imread(str(args.sdd / "annotations" / scene_name / f"video{video}" /
                                   "reference.jpg"))
            for key, value in qualitative(model, scene, row, settings, main_options, image,
                                          eval_params.seed).items():
                arrays[f"{key}_{i}"] = value
            arrays[f"scene_id_{i}"] = np.array(scene_id)
        args.qualitative.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.qualitative.with_name(f".{args.qualitative.stem}.tmp.npz")
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, args.qualitative)


if __name__ == "__main__":
    main()
