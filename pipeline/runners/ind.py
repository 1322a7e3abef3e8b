"""Y-net and the long-term baselines on inD (paper Tables 3/4): what the stages `train_ind` and
`evaluate_ind` share.

Both read the output of `ind_windows` (`pipeline.benchmarks.ind`). When inD was not provided each writes
{"provided": false, "status": "not provided", "reason": ...} at once and exits 0; the report shows
the reason in the inD cells. Otherwise, with the library functions the SDD stages use:

1. Semantic maps of every recording's background (training). With hand-labelled masks
   (`data.ind.labels`) the SDD-trained U-Net is fine-tuned on one labelled background per train
   location (the paper: the SDD model, encoder frozen for the first `freeze_encoder_epochs`, the
   SDD schedule otherwise), and scored on any labelled test background. Without masks (documented
   fallback) the SDD-trained U-Net segments the backgrounds unchanged. Images go to the U-Net
   downsampled by `segmentation_downsample` (paper: 3 for inD); `semantic.source` in the metrics
   says which. The maps are kept in `<checkpoint-dir>/segmentation/maps.npz` for scoring.
2. Y-net (`ynet.<profile>` with inD's `ynet_resize`, authors: 0.33) trained on train, the epoch
   selected on val; scored with TTST + CWS on test over `eval.rounds` rounds, the Table 4 ablation
   and the K_e x K_a grid (`ynet_scoring.evaluation_sequence`, as `evaluate_ynet` does for SDD).
3. S-GAN and PECNet trained on the t_f = 30 windows (selected on val); R-PECNet = a PECNet trained
   on the t_f = 5 windows rolled out to 30 s; constant velocity. Scored as `evaluate_baseline` does.

The benchmark's metrics have the layout of `metrics/ynet_eval.json` ("t_f", "rounds", "main",
"ablation", "ka_grid") plus "baselines": {<model>: the layout of `metrics/baselines/<model>_tf30.json`}.
Every round of each model's test predictions (Y-net: the main setting's paths and sampled goals) is
stored in pixels of the recording's background, one file per model (`write_predictions`; window
ids of the t_f = 30 s table), or, inD not provided, an empty file per model giving the reason.
Checkpoints (`--checkpoint-dir`): ynet/, sgan_tf30/, pecnet_tf30/ and pecnet_tf5/ survive an
interruption and resume (`pipeline.checkpoints`), while a changed run (other windows, maps or
settings) starts afresh; segmentation/model.pt is the fine-tuned U-Net (short; re-trained on every run, seeded).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
import torch

from pipeline.benchmarks.ind import IND, read_index, read_windows
from pipeline.config.runtime import RuntimeParams
from pipeline.data.semantic_maps import iou_summary, predicted_labels, resize_probabilities
from pipeline.data.window_table import WindowArrays, select_split
from pipeline.device import CPU
from pipeline.runners import baseline_runs, baselines
from pipeline.runners.baselines.rpecnet import RecurrentPecnet
from pipeline.harness.model_runs import score_rounds, split_to_score
from pipeline.harness.predictions import PredictionRounds, write_no_predictions
from pipeline.io import atomic_dir, check_array, read_npz, write_npz
from pipeline.model_list import BASELINES, BY_NAME, OURS, RPECNET, TRAINED_BASELINES, YNET
from pipeline.models.constant_velocity import NAME as CONSTANT_VELOCITY, ConstantVelocity
from pipeline.preemption import NEVER, Preemption
from pipeline.runners.segmentation import (downsample_pair, epoch_batches, export_model, learning_rate,
                                           pad_to_multiple, scaled_size, train_step)
from pipeline.runners.segmentation import load_model as load_unet
from pipeline.runners.semantic_maps import predict_probabilities
from pipeline.runners.ynet_scoring import evaluation_sequence, load_for_scoring, sampling_options
from pipeline.runners.ynet_training import train
from ynet.segmentation import N_OUTPUTS, PAD_CLASS, UNet, confusion_matrix

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.cws import CwsParams
    from pipeline.config.eval import EvalParams
    from pipeline.config.evaluate_baseline import EvaluateBaselineParams
    from pipeline.config.ind_benchmark import IndBenchmarkParams
    from pipeline.config.segmentation import SegmentationParams
    from pipeline.config.train_baseline import TrainBaselineParams
    from pipeline.config.ttst import TtstParams
    from pipeline.config.ynet import YnetSettings


MAPS = "segmentation/maps.npz"  # in the checkpoint folder: the maps Y-net trained on, for scoring
REFERENCE = CONSTANT_VELOCITY  # the registered model inD scores beside the paper's
BASELINE_MODELS = (*BASELINES, REFERENCE)
IND_MODELS = (OURS, *BASELINE_MODELS)  # one stored predictions file each


@dataclass(frozen=True)
class IndTrainSettings:
    """What training on inD is configured by, as stage `train_ind` read it from params.yaml."""

    profile: str
    ind: IndBenchmarkParams
    ynet: YnetSettings
    segmentation: SegmentationParams
    baseline_configs: dict[str, Any]  # sgan / pecnet -> their config dataclass
    train_baseline: TrainBaselineParams
    runtime: RuntimeParams = field(default_factory=lambda: RuntimeParams(device="cpu"))


@dataclass(frozen=True)
class IndEvalSettings:
    """What scoring on inD is configured by, as stage `evaluate_ind` read it from params.yaml; the
    models' own settings come from their checkpoints. `threads`: torch threads for the baselines
    (`train_baseline.threads`)."""

    profile: str
    eval: EvalParams
    ttst: TtstParams
    cws: CwsParams
    evaluate_baseline: EvaluateBaselineParams
    threads: int
    runtime: RuntimeParams = field(default_factory=lambda: RuntimeParams(device="cpu"))


@dataclass(frozen=True)
class BenchmarkSettings:
    """Training and scoring settings together (`run_benchmark`; tests pass tiny ones)."""

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

    @property
    def training(self) -> IndTrainSettings:
        return IndTrainSettings(self.profile, self.ind, self.ynet, self.segmentation,
                                self.baseline_configs, self.train_baseline, self.runtime)

    @property
    def evaluation(self) -> IndEvalSettings:
        return IndEvalSettings(self.profile, self.eval, self.ttst, self.cws, self.evaluate_baseline,
                               self.train_baseline.threads, self.runtime)


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


def semantic_maps(ind_dir: Path, index: dict, segmentation_model: Path, settings: IndTrainSettings,
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


def train_ynet(splits: dict[str, WindowArrays], maps: dict[str, np.ndarray],
               sizes: dict[str, tuple[int, int]], settings: IndTrainSettings, n_past: int,
               folder: Path, device: torch.device = CPU, preemption: Preemption = NEVER) -> dict:
    """Train Y-net (val selects the epoch) in `folder`; returns the training summary. A `last.pt`
    there resumes only if written for the same windows, maps and settings (its identity,
    `pipeline.checkpoints`), as for every Y-net training."""
    ynet_settings = replace(settings.ynet, resize=settings.ind.ynet_resize)
    folder.mkdir(parents=True, exist_ok=True)
    return train(splits["train"], splits["val"], maps, sizes, ynet_settings, n_past,
                 folder / "last.pt", folder / "best.pt", folder / "history.csv", device=device,
                 preemption=preemption)


def score_ynet(test: WindowArrays, maps: dict[str, np.ndarray], sizes: dict[str, tuple[int, int]],
               settings: IndEvalSettings, folder: Path, device: torch.device = CPU,
               kept: PredictionRounds | None = None) -> dict:
    """The best epoch in `folder` (its settings from the checkpoint) on test: the main result,
    ablation and K_a grid; `kept` receives the main result's rounds."""
    model, ynet_settings, scenes = load_for_scoring(folder / "best.pt", test, maps, sizes,
                                                    settings.eval.threads, device)
    params = settings.eval
    return {"n_windows": len(test), "rounds": params.rounds, "resize": ynet_settings.resize,
            **evaluation_sequence(model, scenes, ynet_settings, params, settings.ttst, settings.cws,
                                  test.future, label="inD ", kept=kept)}


def baseline_dirs(checkpoint_dir: Path, horizon: int, base_horizon: int) -> dict[str, Path]:
    """baseline -> its checkpoint folder (R-PECNet: the PECNet of the base horizon)."""
    dirs = {model: checkpoint_dir / f"{model}_tf{horizon}" for model in TRAINED_BASELINES}
    return {**dirs, RPECNET: checkpoint_dir / f"{BY_NAME[RPECNET].trained_as}_tf{base_horizon}"}


def train_baselines(long: WindowArrays, base: WindowArrays, settings: IndTrainSettings,
                    checkpoint_dir: Path, device: torch.device = CPU,
                    preemption: Preemption = NEVER) -> dict[str, dict]:
    """Train S-GAN and PECNet on the long windows and PECNet on the base ones (R-PECNet's);
    returns each checkpoint folder's training facts."""
    seed = settings.train_baseline.seed
    torch.set_num_threads(settings.train_baseline.threads)
    dirs = baseline_dirs(checkpoint_dir, long.future.shape[1], base.future.shape[1])
    facts = {}
    for model in TRAINED_BASELINES:
        facts[model] = baseline_runs.train(model, long, settings.baseline_configs[model], dirs[model],
                                           seed, device, preemption)
    base_model = BY_NAME[RPECNET].trained_as
    facts[RPECNET] = baseline_runs.train(base_model, base, settings.baseline_configs[base_model],
                                         dirs[RPECNET], seed, device, preemption)
    return facts


def score_baselines(long: WindowArrays, base: WindowArrays, settings: IndEvalSettings,
                    checkpoint_dir: Path, device: torch.device = CPU
                    ) -> tuple[dict[str, dict], dict[str, PredictionRounds]]:
    """model -> scores in the layout of metrics/baselines/<model>_tf30.json, and model -> every
    round's predictions, as scored: the paper's baselines and the reference, constant velocity
    (nothing to fit, so no workdir of its own), all through the models' contract and one loop."""
    evaluation = settings.evaluate_baseline
    torch.set_num_threads(settings.threads)
    horizon = long.future.shape[1]
    dirs = baseline_dirs(checkpoint_dir, horizon, base.future.shape[1])
    test, truth = split_to_score(long, evaluation.split)
    models = {model: baselines.Baseline(model, device=device) for model in BASELINES}
    results, kept = {}, {}
    for model in BASELINE_MODELS:
        if model == REFERENCE:
            scored, workdir, facts = ConstantVelocity({}), checkpoint_dir, {"train_seconds": 0.0}
        else:
            scored, workdir = models[model], dirs[model]
            scored.loaded(workdir)  # before the clock, as for every scored model
            facts = baseline_runs.training_facts(model, workdir)
        kept[model] = PredictionRounds(test.window_id)
        scores = score_rounds(model, scored, test, truth, workdir, evaluation.k, evaluation.rounds,
                              evaluation.seed, kept[model])
        results[model] = {"model": model, "horizon": horizon, "split": evaluation.split,
                          "seed": evaluation.seed, **scores, **facts}
    return results, kept


# ---------------------------------------------------------------------------------------------
# Stored predictions


def write_predictions(folder: Path, predictions: dict[str, tuple[PredictionRounds, dict]],
                      not_provided: str | None = None) -> None:
    """`<folder>/<model>.parquet` for every model of `IND_MODELS`, the folder replaced as a whole:
    each model's rounds and metadata from `predictions` (what `evaluate_benchmark` returns), or,
    where inD was `not_provided` (the reason), empty files that give it."""
    with atomic_dir(folder) as tmp:
        for model in IND_MODELS:
            path = tmp / f"{model}.parquet"
            if not_provided is not None:
                write_no_predictions(path, IND.prediction_metadata(model), not_provided)
            else:
                rounds, metadata = predictions[model]
                rounds.write(path, metadata)


# ---------------------------------------------------------------------------------------------
# The benchmark


@dataclass(frozen=True)
class IndData:
    """The inD windows as the benchmark uses them."""

    index: dict
    long: WindowArrays  # t_f = 30 s, every split
    base: WindowArrays  # t_f = 5 s: R-PECNet's PECNet
    splits: dict[str, WindowArrays]  # train / val / test of `long`

    @property
    def sizes(self) -> dict[str, tuple[int, int]]:
        return {name: (info["height"], info["width"]) for name, info in self.index["scenes"].items()}


def read_maps(checkpoint_dir: Path, index: dict, ind_dir: Path) -> dict[str, np.ndarray]:
    """The maps `train_benchmark` kept: one finite float32 (C, H, W) per scene of the index."""
    path = checkpoint_dir / MAPS
    stored = read_npz(path, index["scenes"], Path(ind_dir) / "index.json")
    return {name: check_array(array, np.float32, (N_OUTPUTS, None, None), path, name)
            for name, array in stored.items()}


def read_data(ind_dir: Path, index: dict) -> IndData:
    long = read_windows(ind_dir, index, index["horizon"])
    base = read_windows(ind_dir, index, RecurrentPecnet.base_horizon)
    splits = {split: select_split(long, split) for split in ("train", "val", "test")}
    empty = [split for split, arrays in splits.items() if len(arrays) == 0]
    if empty:
        raise ValueError(f"{ind_dir}: no t_f = {index['horizon']} s windows in split(s) {empty} "
                         "(test: location 4; val: data.ind.val_recordings); see metrics/ind_windows.json")
    return IndData(index, long, base, splits)


def train_benchmark(ind_dir: Path, segmentation_model: Path, checkpoint_dir: Path,
                    settings: IndTrainSettings, device: torch.device = CPU,
                    preemption: Preemption = NEVER) -> dict:
    """Train everything into `checkpoint_dir`; returns the training record (or why there is none)."""
    index = read_index(ind_dir)  # checked before anything is written
    checkpoint_dir.mkdir(parents=True, exist_ok=True)
    if not index["provided"]:
        return not_provided_record(index["reason"])
    data = read_data(ind_dir, index)
    start = time.perf_counter()
    maps, semantic = semantic_maps(ind_dir, index, segmentation_model, settings,
                                   checkpoint_dir / "segmentation", device)
    write_npz(checkpoint_dir / MAPS, maps)
    ynet = train_ynet(data.splits, maps, data.sizes, settings, index["n_past"],
                      checkpoint_dir / YNET, device, preemption)
    trained = train_baselines(data.long, data.base, settings, checkpoint_dir, device, preemption)
    return {"provided": True, "status": "ok", "profile": settings.profile,
            "t_f": int(index["horizon"]), "windows": {s: len(a) for s, a in data.splits.items()},
            "semantic": semantic, YNET: ynet, "baselines": trained,
            "seconds": time.perf_counter() - start}


def evaluate_benchmark(ind_dir: Path, checkpoint_dir: Path, trained: dict, settings: IndEvalSettings,
                       device: torch.device = CPU
                       ) -> tuple[dict, dict[str, tuple[PredictionRounds, dict]]]:
    """Score what `train_benchmark` trained (`trained`: its record); returns the metrics record and,
    per model of `IND_MODELS`, every round of its test predictions (Y-net: the main setting's) with
    the metadata its file records (`write_predictions`; none where inD was not provided)."""
    index = read_index(ind_dir)
    if not index["provided"]:
        return not_provided_record(index["reason"]), {}
    data = read_data(ind_dir, index)
    start = time.perf_counter()
    maps = read_maps(checkpoint_dir, index, ind_dir)
    ynet_rounds = PredictionRounds(data.splits["test"].window_id)
    ynet = score_ynet(data.splits["test"], maps, data.sizes, settings, checkpoint_dir / YNET,
                      device, ynet_rounds)
    scores, kept = score_baselines(data.long, data.base, settings, checkpoint_dir, device)
    table = Path(ind_dir) / index["tables"][str(index["horizon"])]
    options = sampling_options(settings.eval.k_e, settings.eval.k_a, settings.ttst, settings.cws,
                               True, True)
    predictions = {YNET: (ynet_rounds, IND.prediction_metadata(
        YNET, table, k=options.K, k_e=options.K_e, k_a=options.K_a,
        sampling=dataclasses.asdict(options), checkpoint=str(checkpoint_dir / YNET / "best.pt")))}
    dirs = baseline_dirs(checkpoint_dir, data.long.future.shape[1], data.base.future.shape[1])
    for model, rounds in kept.items():
        predictions[model] = (rounds, IND.prediction_metadata(
            model, table, split=settings.evaluate_baseline.split, k=settings.evaluate_baseline.k,
            checkpoint_dir=str(dirs[model]) if model in dirs else None))  # constant velocity: none
    record = {
        "provided": True, "status": "ok", "profile": settings.profile,
        "t_f": int(index["horizon"]), "k_e": settings.eval.k_e,
        "windows": {split: len(arrays) for split, arrays in data.splits.items()},
        **ynet, "train": trained[YNET],
        "semantic": trained["semantic"],
        "baselines": scores,
        "seconds": trained["seconds"] + time.perf_counter() - start,
    }
    return record, predictions


def run_benchmark(ind_dir: Path, segmentation_model: Path, checkpoint_dir: Path,
                  settings: BenchmarkSettings, device: torch.device = CPU,
                  preemption: Preemption = NEVER
                  ) -> tuple[dict, dict[str, tuple[PredictionRounds, dict]]]:
    """Train, then score: the two stages in one call (tests); returns what `evaluate_benchmark`
    returns."""
    trained = train_benchmark(ind_dir, segmentation_model, checkpoint_dir, settings.training, device,
                              preemption)
    if not trained["provided"]:
        return trained, {}
    return evaluate_benchmark(ind_dir, checkpoint_dir, trained, settings.evaluation, device)
