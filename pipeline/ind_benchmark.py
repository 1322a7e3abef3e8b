"""Stage `ind_benchmark`: Y-net and the long-term baselines trained and scored on inD (paper Table 3/4).

Reads the output of `ind_windows` (`pipeline.ind`). When inD was not provided it writes
{"provided": false, "status": "not provided", "reason": ...} at once and exits 0; the report shows
the reason in the inD cells. Otherwise, with the library functions the SDD stages use:

1. Semantic maps of every recording's background. With hand-labelled masks (`data.ind.labels`) the
   SDD-trained U-Net is fine-tuned on one labelled background per train location (the paper: the
   SDD model, encoder frozen for the first `freeze_encoder_epochs`, the SDD schedule otherwise),
   and scored on any labelled test background. Without masks (documented fallback) the SDD-trained
   U-Net segments the backgrounds unchanged. Images go to the U-Net downsampled by
   `segmentation_downsample` (paper: 3 for inD); `semantic.source` in the metrics says which.
2. Y-net (`ynet.<profile>` with inD's `ynet_resize`, authors: 0.33) trained on train, the epoch
   selected on val, then TTST + CWS on test over `eval.rounds` rounds, the Table 4 ablation and the
   K_e x K_a grid, as `evaluate_ynet` does for SDD.
3. S-GAN and PECNet trained on the t_f = 30 windows (selected on val); R-PECNet = a PECNet trained
   on the t_f = 5 windows rolled out to 30 s; constant velocity. Scored as `evaluate_baseline` does.

The metrics file has the layout of `metrics/ynet_eval.json` ("t_f", "rounds", "main", "ablation",
"ka_grid") plus "baselines": {<model>: the layout of `metrics/baselines/<model>_tf30.json`}.
Checkpoints (`--checkpoint-dir`): ynet/, sgan_tf30/, pecnet_tf30/ and pecnet_tf5/ survive an
interruption and resume, while a changed run (other windows, maps or settings) starts afresh;
segmentation/model.pt is the fine-tuned U-Net (short; re-trained on every run, seeded).

    python -m pipeline.ind_benchmark --ind data/ind --segmentation-model data/segmentation/model.pt \
        --checkpoint-dir checkpoints/ind --metrics metrics/ind_benchmark.json
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import shutil
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pandas as pd
import torch

from pipeline import baselines, train_baseline
from pipeline.baselines.common import select_split
from pipeline.baselines.rpecnet import RecurrentPecnet
from pipeline.device import CPU, RuntimeParams, describe, select_device
from pipeline.evaluate_baseline import EvaluateBaselineParams, training_facts
from pipeline.evaluate_baseline import evaluate as evaluate_baseline
from pipeline.evaluate_ynet import (CwsParams, EvalParams, TtstParams, evaluate, load_model,
                                    sampling_options)
from pipeline.params import load_profile, load_section, read_params
from pipeline.preemption import NEVER, Preemption, exit_when_stopped
from pipeline.segmentation import (SegmentationParams, downsample_pair, epoch_batches, export_model,
                                   learning_rate, pad_to_multiple, scaled_size, train_step)
from pipeline.segmentation import load_model as load_unet
from pipeline.semantic_maps import (iou_summary, predict_probabilities, predicted_labels,
                                    resize_probabilities)
from pipeline.train_baseline import TrainBaselineParams
from pipeline.train_ynet import YnetSettings, train
from pipeline.window_table import WindowArrays, to_arrays
from pipeline.windows import write_json_atomic
from pipeline.ynet_data import group_by_scene
from ynet.segmentation import N_OUTPUTS, PAD_CLASS, UNet, confusion_matrix

TRAINED_BASELINES = ("sgan", "pecnet")  # trained on the t_f = 30 windows


@dataclass(frozen=True)
class IndBenchmarkParams:
    """Section `ind_benchmark.<profile>` of params.yaml: what differs on inD from SDD."""

    ynet_resize: float
    """Y-net's map and coordinate scale on inD backgrounds (authors: 0.33; SDD 0.25)."""
    segmentation_downsample: int
    """The U-Net sees inD backgrounds downsampled by this factor (paper: 3; SDD 4)."""
    freeze_encoder_epochs: int
    """Fine-tuning epochs (of `segmentation.<profile>.epochs`) with the U-Net encoder frozen."""

    def __post_init__(self) -> None:
        if not 0 < self.ynet_resize <= 1:
            raise ValueError(f"ynet_resize must be in (0, 1], got {self.ynet_resize}")
        if self.segmentation_downsample < 1 or self.freeze_encoder_epochs < 0:
            raise ValueError("need segmentation_downsample >= 1 and freeze_encoder_epochs >= 0")


@dataclass(frozen=True)
class BenchmarkSettings:
    """Everything the benchmark is configured by: `from_params` reads params.yaml; tests pass tiny ones."""

    profile: str
    ind: IndBenchmarkParams
    ynet: YnetSettings
    eval: EvalParams
    ttst: TtstParams
    cws: CwsParams
    segmentation: SegmentationParams
    baseline_configs: dict[str, Any]  # sgan / pecnet -> their config dataclass
    train_baseline: TrainBaselineParams
    evaluate_baseline: EvaluateBaselineParams
    runtime: RuntimeParams = field(default_factory=lambda: RuntimeParams(device="cpu"))

    @classmethod
    def from_params(cls, params: dict) -> BenchmarkSettings:
        return cls(
            profile=params["profile"],
            ind=load_profile(IndBenchmarkParams, "ind_benchmark", params),
            ynet=load_profile(YnetSettings, "ynet", params),
            eval=load_profile(EvalParams, "eval", params),
            ttst=load_section(TtstParams, "ttst", params),
            cws=load_section(CwsParams, "cws", params),
            segmentation=load_profile(SegmentationParams, "segmentation", params),
            baseline_configs={m: train_baseline.model_config(m, params) for m in TRAINED_BASELINES},
            train_baseline=load_section(TrainBaselineParams, "train_baseline", params),
            evaluate_baseline=load_section(EvaluateBaselineParams, "evaluate_baseline", params),
            runtime=load_section(RuntimeParams, "runtime", params),
        )


def not_provided_record(reason: str) -> dict:
    """What the report shows in the inD cells (its `status` / `reason` convention)."""
    return {"provided": False, "status": "not provided", "reason": reason}


# ---------------------------------------------------------------------------------------------
# Semantic maps


def read_image(path: Path, flags: int = cv2.IMREAD_COLOR) -> np.ndarray:
    image = cv2.imread(str(path), flags)
    if image is None:
        raise FileNotFoundError(f"{path}: missing or unreadable")
    return image


def one_per_location(scenes: dict[str, dict], names: list[str]) -> list[str]:
    """The first of `names` at each location: recordings of one place share one background."""
    seen, chosen = set(), []
    for name in sorted(names):
        if scenes[name]["location"] not in seen:
            seen.add(scenes[name]["location"])
            chosen.append(name)
    return chosen


def encoder_parameters(model: UNet) -> list[torch.nn.Parameter]:
    return [*model.stem.parameters(), *model.downs.parameters()]


def finetune(model: UNet, scenes: list[tuple[np.ndarray, np.ndarray]], params: SegmentationParams,
             freeze_epochs: int) -> list[dict]:
    """Fine-tune `model` in place on downsampled, padded (image, labels) pairs; returns the epoch log.

    The encoder (stem and down blocks) gets no gradient and keeps its BatchNorm statistics for the
    first `freeze_epochs` epochs; crops, augmentation, loss and schedule are the SDD training's.
    """
    torch.manual_seed(params.seed)
    if params.bf16:
        model = model.to(memory_format=torch.channels_last)
    optimiser = torch.optim.Adam(model.parameters(), lr=params.lr)
    log = []
    for epoch in range(params.epochs):
        frozen = epoch < freeze_epochs
        model.train()
        for p in encoder_parameters(model):
            p.requires_grad_(not frozen)
        if frozen:
            model.stem.eval()
            model.downs.eval()
        for group in optimiser.param_groups:
            group["lr"] = learning_rate(params, epoch)
        start = time.perf_counter()
        losses = [train_step(model, optimiser, images, labels, params.bf16)
                  for images, labels in epoch_batches(scenes, params, epoch)]
        log.append({"epoch": epoch + 1, "loss": float(np.mean(losses)), "lr": learning_rate(params, epoch),
                    "crops": len(scenes) * params.crops_per_image, "encoder_frozen": frozen,
                    "seconds": round(time.perf_counter() - start, 3)})
    for p in encoder_parameters(model):
        p.requires_grad_(True)
    model.eval()
    return log


def semantic_maps(ind_dir: Path, index: dict, segmentation_model: Path, settings: BenchmarkSettings,
                  work_dir: Path, device: torch.device = CPU
                  ) -> tuple[dict[str, np.ndarray], dict]:
    """scene_id -> (C, H, W) class probabilities at Y-net's resolution, and what was done.

    The U-Net fine-tunes and segments on `device`. Its fine-tuning takes minutes and keeps no
    checkpoint of its own, so a stop request is only honoured after it (by Y-net's training)."""
    scenes = index["scenes"]
    model, meta = load_unet(segmentation_model, device)
    downsample = settings.ind.segmentation_downsample
    labelled = [name for name, info in scenes.items() if info["labels"]]
    facts: dict[str, Any] = {"segmentation_downsample": downsample,
                             "sdd_model": {"unet": meta["unet"], "epochs": meta["epochs"]}}
    if labelled:
        params = replace(settings.segmentation, base_channels=meta["unet"]["base_channels"],
                         depth=meta["unet"]["depth"], pad_multiple=meta["pad_multiple"],
                         downsample=downsample)
        names = one_per_location(scenes, [n for n in labelled if scenes[n]["split"] != "test"])
        pairs = []
        for name in names:
            image, labels = downsample_pair(read_image(ind_dir / scenes[name]["image"]),
                                            read_image(ind_dir / scenes[name]["labels"],
                                                       cv2.IMREAD_UNCHANGED), downsample)
            pairs.append((pad_to_multiple(image, params.pad_multiple),
                          pad_to_multiple(labels, params.pad_multiple, PAD_CLASS)))
        log = finetune(model, pairs, params, settings.ind.freeze_encoder_epochs)
        export_model(work_dir / "model.pt", model, params, settings.profile, names, log)
        facts |= {"source": "finetuned", "train_scenes": names, "epochs": len(log),
                  "freeze_encoder_epochs": min(settings.ind.freeze_encoder_epochs, len(log)),
                  "final_dice_loss": log[-1]["loss"] if log else None,
                  "train_seconds": round(sum(row["seconds"] for row in log), 1)}
    else:
        facts |= {"source": "sdd_unet",
                  "note": "no inD label masks (data.ind.labels empty): the SDD-trained U-Net "
                          "segments the inD backgrounds unchanged (the paper fine-tunes it on "
                          "labelled train-location backgrounds)"}

    maps = {}
    scored = one_per_location(scenes, [n for n in labelled if scenes[n]["split"] == "test"])
    confusion = np.zeros((N_OUTPUTS, N_OUTPUTS), np.int64)
    for name, info in sorted(scenes.items()):
        image = read_image(ind_dir / info["image"])
        hw = scaled_size(*image.shape[:2], settings.ind.ynet_resize)
        small = scaled_size(*image.shape[:2], 1 / downsample)
        net_input = cv2.resize(image, (small[1], small[0]), interpolation=cv2.INTER_AREA)
        maps[name] = resize_probabilities(
            predict_probabilities(model, net_input, meta["pad_multiple"]), hw)  # (C, H, W)
        if name in scored:  # a labelled test background: how good are the maps Y-net is given?
            labels = cv2.resize(read_image(ind_dir / info["labels"], cv2.IMREAD_UNCHANGED),
                                (hw[1], hw[0]), interpolation=cv2.INTER_NEAREST)  # (H, W)
            confusion += confusion_matrix(torch.from_numpy(predicted_labels(maps[name])),
                                          torch.from_numpy(labels), N_OUTPUTS).numpy()
    if scored:
        facts["test"] = {"scenes": scored, **iou_summary(confusion)}
    return maps, facts


# ---------------------------------------------------------------------------------------------
# Y-net and baselines


def array_digest(digest, arrays: WindowArrays) -> None:
    for values in (arrays.window_id, arrays.first_frame, arrays.past, arrays.future):
        digest.update(np.ascontiguousarray(values).tobytes())
    digest.update("\0".join(arrays.scene_id.astype(str)).encode())


def fresh_or_resumable(folder: Path, key: str) -> None:
    """Keep `folder` (a checkpoint directory) only if it was written for run `key`; else empty it.

    Y-net's `train` resumes from any last.pt it finds, so a run on other windows, maps or settings
    must not find one (more epochs, or other threads, may resume).
    """
    stamp = folder / "run.txt"
    if folder.exists() and (not stamp.is_file() or stamp.read_text() != key):
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stamp.write_text(key)


def ynet_benchmark(splits: dict[str, WindowArrays], maps: dict[str, np.ndarray],
                   sizes: dict[str, tuple[int, int]], settings: BenchmarkSettings, n_past: int,
                   folder: Path, device: torch.device = CPU,
                   preemption: Preemption = NEVER) -> dict:
    """Train Y-net (val selects the epoch), then the main result, ablation and K_a grid on test."""
    ynet_settings = replace(settings.ynet, resize=settings.ind.ynet_resize)
    kept = {k: v for k, v in dataclasses.asdict(ynet_settings).items() if k not in ("epochs", "threads")}
    digest = hashlib.sha256(json.dumps([kept, n_past], sort_keys=True).encode())
    for split in ("train", "val"):
        array_digest(digest, splits[split])
    for name in sorted(maps):
        digest.update(maps[name].tobytes())
    fresh_or_resumable(folder, digest.hexdigest())
    summary = train(splits["train"], splits["val"], maps, sizes, ynet_settings, n_past,
                    folder / "last.pt", folder / "best.pt", folder / "history.csv", device=device,
                    preemption=preemption)

    model, ynet_settings = load_model(folder / "best.pt", device)
    test = splits["test"]
    scenes = group_by_scene(test, maps, sizes, ynet_settings.resize, device)
    params = settings.eval

    def run(k_e: int, k_a: int, ttst: bool, cws: bool, rounds: int, desc: str) -> dict:
        options = sampling_options(k_e, k_a, settings.ttst, settings.cws, ttst, cws)
        return evaluate(model, scenes, ynet_settings, options, params, test.future, rounds, desc)

    start = time.perf_counter()
    result = {"n_windows": len(test), "rounds": params.rounds, "resize": ynet_settings.resize,
              "main": run(params.k_e, params.k_a, True, True, params.rounds, "inD TTST+CWS")}
    result["main_seconds"] = time.perf_counter() - start
    if params.ablation_rounds:
        result["ablation"] = {"ttst_cws": result["main"]}
        for name, ttst, cws in (("none", False, False), ("cws", False, True)):
            result["ablation"][name] = run(params.k_e, params.k_a, ttst, cws, params.ablation_rounds,
                                           f"inD {name}")
    if params.ka_grid_k_e:
        result["ka_grid"] = [run(k_e, k_a, True, True, 1, f"inD K_e={k_e} K_a={k_a}")
                             for k_e in params.ka_grid_k_e for k_a in params.ka_grid_k_a]
    result["eval_seconds"] = time.perf_counter() - start
    result["train"] = summary
    return result


def baseline_benchmark(long: WindowArrays, base: WindowArrays, settings: BenchmarkSettings,
                       checkpoint_dir: Path, device: torch.device = CPU,
                       preemption: Preemption = NEVER) -> dict[str, dict]:
    """model -> scores in the layout of metrics/baselines/<model>_tf30.json."""
    seed, evaluation = settings.train_baseline.seed, settings.evaluate_baseline
    torch.set_num_threads(settings.train_baseline.threads)
    horizon, base_horizon = long.future.shape[1], base.future.shape[1]
    test = select_split(long, evaluation.split)
    results, dirs = {}, {}
    for model in TRAINED_BASELINES:
        dirs[model] = checkpoint_dir / f"{model}_tf{horizon}"
        train_baseline.train(model, long, settings.baseline_configs[model], dirs[model], seed,
                             device, preemption)
    dirs["rpecnet"] = checkpoint_dir / f"pecnet_tf{base_horizon}"
    train_baseline.train("pecnet", base, settings.baseline_configs["pecnet"], dirs["rpecnet"], seed,
                         device, preemption)
    for model in (*TRAINED_BASELINES, "rpecnet", "constant_velocity"):
        trained = dirs.get(model)
        fitted = baselines.get(model).load(trained, device)
        scores = evaluate_baseline(fitted, test, evaluation.k, evaluation.rounds, evaluation.seed,
                                   device)
        results[model] = {"model": model, "horizon": horizon, "split": evaluation.split,
                          "seed": evaluation.seed, **scores, **training_facts(model, trained)}
    return results


# ---------------------------------------------------------------------------------------------
# The stage


def read_windows(ind_dir: Path, index: dict, horizon: int) -> WindowArrays:
    name = index["tables"].get(str(horizon))
    if name is None:
        raise ValueError(f"{ind_dir}/index.json: no window table for t_f = {horizon} s")
    return to_arrays(pd.read_parquet(ind_dir / name), index["n_past"])


def run_benchmark(ind_dir: Path, segmentation_model: Path, checkpoint_dir: Path,
                  settings: BenchmarkSettings, device: torch.device = CPU,
                  preemption: Preemption = NEVER) -> dict:
    """The metrics record (results, or why there are none); checkpoints go to `checkpoint_dir`."""
    checkpoint_dir.mkdir(parents=True, exist_ok=True)
    index = json.loads((ind_dir / "index.json").read_text())
    if not index["provided"]:
        return not_provided_record(index["reason"])

    long = read_windows(ind_dir, index, index["horizon"])
    base = read_windows(ind_dir, index, RecurrentPecnet.base_horizon)
    splits = {split: select_split(long, split) for split in ("train", "val", "test")}
    empty = [split for split, arrays in splits.items() if len(arrays) == 0]
    if empty:
        raise ValueError(f"{ind_dir}: no t_f = {index['horizon']} s windows in split(s) {empty} "
                         "(test: location 4; val: data.ind.val_recordings); see metrics/ind_windows.json")
    start = time.perf_counter()
    maps, semantic = semantic_maps(ind_dir, index, segmentation_model, settings,
                                   checkpoint_dir / "segmentation", device)
    sizes = {name: (info["height"], info["width"]) for name, info in index["scenes"].items()}
    ynet = ynet_benchmark(splits, maps, sizes, settings, index["n_past"], checkpoint_dir / "ynet",
                          device, preemption)
    return {
        "provided": True, "status": "ok", "profile": settings.profile,
        "t_f": int(index["horizon"]), "k_e": settings.eval.k_e,
        "windows": {split: len(arrays) for split, arrays in splits.items()},
        **ynet,
        "semantic": semantic,
        "baselines": baseline_benchmark(long, base, settings, checkpoint_dir, device, preemption),
        "seconds": time.perf_counter() - start,
    }


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ind", type=Path, required=True, help="output folder of stage ind_windows")
    parser.add_argument("--segmentation-model", type=Path, required=True,
                        help="the SDD-trained U-Net (stage segmentation)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True)
    args = parser.parse_args(argv)
    settings = BenchmarkSettings.from_params(read_params())
    device = select_device(settings.runtime.device)
    print(f"ind_benchmark: on {describe(device)}")
    with Preemption(settings.runtime.max_minutes) as preemption:
        result = run_benchmark(args.ind, args.segmentation_model, args.checkpoint_dir, settings,
                               device, preemption)
    write_json_atomic(result, args.metrics)
    if not result["provided"]:
        print(f"ind_benchmark: inD not provided: {result['reason']}")
        return
    main_result = result["main"]
    print(f"ind_benchmark: Y-net ADE {main_result['ade']['mean']:.2f}  FDE {main_result['fde']['mean']:.2f}; "
          + "  ".join(f"{m} ADE {r['ade']:.2f}" for m, r in result["baselines"].items()))


if __name__ == "__main__":
    main()
