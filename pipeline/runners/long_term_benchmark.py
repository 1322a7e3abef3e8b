"""Y-net and the long-term baselines scored on a long-term benchmark of its own folder (inD, paper
Tables 3/4: stage `evaluate_ind`), and what its training (`pipeline.runners.long_term_training`,
stage `train_ind`) shares with the scoring: where things lie in the checkpoint folder.

The benchmark object (`pipeline.benchmarks.long_term.LongTermBenchmark`) says what its folder
holds (`not_provided`, `load`) and what its predictions files record (`prediction_metadata`); the
models and how they run are the SDD stages' library functions:

- Y-net (its settings from the checkpoint) with TTST + CWS on test over `eval.rounds` rounds, the
  Table 4 ablation and the K_e x K_a grid (`ynet_scoring.evaluation_sequence`, as `evaluate_ynet`
  does for SDD), on the semantic maps training kept (`MAPS`);
- S-GAN and PECNet trained on the benchmark's horizon, R-PECNet = a PECNet trained on the base
  horizon rolled out, and the reference, constant velocity; scored as `evaluate_baseline` does.

The metrics have the layout of `metrics/ynet_eval.json` ("t_f", "rounds", "main", "ablation",
"ka_grid") plus "baselines": {<model>: the layout of `metrics/baselines/<model>_tf30.json`}. Every
round of each model's test predictions (Y-net: the main setting's paths and sampled goals) is
stored in the benchmark's unit, one file per model (`write_predictions`; window ids of its table),
or, the benchmark not provided, an empty file per model giving the reason.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from pipeline.config.runtime import RuntimeParams
from pipeline.data.window_table import WindowArrays
from pipeline.device import CPU
from pipeline.harness.model_runs import score_rounds, split_to_score
from pipeline.harness.predictions import PredictionRounds, write_no_predictions
from pipeline.io import atomic_dir, check_array, read_npz
from pipeline.model_list import BASELINES, BY_NAME, OURS, RPECNET, TRAINED_BASELINES, YNET
from pipeline.models.constant_velocity import NAME as CONSTANT_VELOCITY, ConstantVelocity
from pipeline.runners import baseline_runs, baselines
from pipeline.runners.ynet_scoring import evaluation_sequence, load_for_scoring, sampling_options
from ynet.classes import N_OUTPUTS

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.benchmarks.long_term import LongTermBenchmark
    from pipeline.config.cws import CwsParams
    from pipeline.config.eval import EvalParams
    from pipeline.config.evaluate_baseline import EvaluateBaselineParams
    from pipeline.config.ttst import TtstParams


MAPS = "segmentation/maps.npz"  # in the checkpoint folder: the maps Y-net trained on, for scoring
REFERENCE = CONSTANT_VELOCITY  # the registered model a long-term benchmark scores beside the paper's
BASELINE_MODELS = (*BASELINES, REFERENCE)
MODELS = (OURS, *BASELINE_MODELS)  # one stored predictions file each


@dataclass(frozen=True)
class EvalSettings:
    """What scoring is configured by, as the stage read it from params.yaml; the models' own
    settings come from their checkpoints. `threads`: torch threads for the baselines
    (`train_baseline.threads`)."""

    profile: str
    eval: EvalParams
    ttst: TtstParams
    cws: CwsParams
    evaluate_baseline: EvaluateBaselineParams
    threads: int
    runtime: RuntimeParams = field(default_factory=lambda: RuntimeParams(device="cpu"))


def not_provided_record(reason: str) -> dict:
    """What the report shows in the benchmark's cells (its `status` / `reason` convention)."""
    return {"provided": False, "status": "not provided", "reason": reason}


def baseline_dirs(checkpoint_dir: Path, horizon: int, base_horizon: int) -> dict[str, Path]:
    """baseline -> its checkpoint folder (R-PECNet: the PECNet of the base horizon)."""
    dirs = {model: checkpoint_dir / f"{model}_tf{horizon}" for model in TRAINED_BASELINES}
    return {**dirs, RPECNET: checkpoint_dir / f"{BY_NAME[RPECNET].trained_as}_tf{base_horizon}"}


def read_maps(path: Path, scenes: Collection[str], index: Path) -> dict[str, np.ndarray]:
    """The maps training kept at `path`: one finite float32 (C, H, W) per scene `index` lists."""
    stored = read_npz(path, scenes, index)
    return {name: check_array(array, np.float32, (N_OUTPUTS, None, None), path, name)
            for name, array in stored.items()}


def score_ynet(test: WindowArrays, maps: dict[str, np.ndarray], sizes: dict[str, tuple[int, int]],
               settings: EvalSettings, folder: Path, label: str, device: torch.device = CPU,
               kept: PredictionRounds | None = None) -> dict:
    """The best epoch in `folder` (its settings from the checkpoint) on test: the main result,
    ablation and K_a grid; `kept` receives the main result's rounds."""
    model, ynet_settings, scenes = load_for_scoring(folder / "best.pt", test, maps, sizes,
                                                    settings.eval.threads, device)
    params = settings.eval
    return {"n_windows": len(test), "rounds": params.rounds, "resize": ynet_settings.resize,
            **evaluation_sequence(model, scenes, ynet_settings, params, settings.ttst, settings.cws,
                                  test.future, label=f"{label} ", kept=kept)}


def score_baselines(long: WindowArrays, base: WindowArrays, settings: EvalSettings,
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


def write_predictions(benchmark: LongTermBenchmark, folder: Path,
                      predictions: dict[str, tuple[PredictionRounds, dict]],
                      not_provided: str | None = None) -> None:
    """`<folder>/<model>.parquet` for every model of `MODELS`, the folder replaced as a whole:
    each model's rounds and metadata from `predictions` (what `evaluate_benchmark` returns), or,
    where the benchmark was `not_provided` (the reason), empty files that give it."""
    with atomic_dir(folder) as tmp:
        for model in MODELS:
            path = tmp / f"{model}.parquet"
            if not_provided is not None:
                write_no_predictions(path, benchmark.prediction_metadata(model), not_provided)
            else:
                rounds, metadata = predictions[model]
                rounds.write(path, metadata)


def evaluate_benchmark(benchmark: LongTermBenchmark, folder: Path, checkpoint_dir: Path,
                       trained: dict, settings: EvalSettings, device: torch.device = CPU
                       ) -> tuple[dict, dict[str, tuple[PredictionRounds, dict]]]:
    """Score what `long_term_training.train_benchmark` trained (`trained`: its record) on the
    benchmark's `folder`; returns the metrics record and, per model of `MODELS`, every round of
    its test predictions (Y-net: the main setting's) with the metadata its file records
    (`write_predictions`; none where the benchmark was not provided)."""
    reason = benchmark.not_provided(folder)
    if reason is not None:
        return not_provided_record(reason), {}
    data = benchmark.load(folder)
    start = time.perf_counter()
    maps = read_maps(checkpoint_dir / MAPS, data.sizes, data.index)
    ynet_rounds = PredictionRounds(data.splits["test"].window_id)
    ynet = score_ynet(data.splits["test"], maps, data.sizes, settings, checkpoint_dir / YNET,
                      benchmark.label, device, ynet_rounds)
    scores, kept = score_baselines(data.long, data.base, settings, checkpoint_dir, device)
    options = sampling_options(settings.eval.k_e, settings.eval.k_a, settings.ttst, settings.cws,
                               True, True)
    predictions = {YNET: (ynet_rounds, benchmark.prediction_metadata(
        YNET, data.table, k=options.K, k_e=options.K_e, k_a=options.K_a,
        sampling=dataclasses.asdict(options), checkpoint=str(checkpoint_dir / YNET / "best.pt")))}
    dirs = baseline_dirs(checkpoint_dir, data.long.future.shape[1], data.base.future.shape[1])
    for model, rounds in kept.items():
        predictions[model] = (rounds, benchmark.prediction_metadata(
            model, data.table, split=settings.evaluate_baseline.split, k=settings.evaluate_baseline.k,
            checkpoint_dir=str(dirs[model]) if model in dirs else None))  # constant velocity: none
    record = {
        "provided": True, "status": "ok", "profile": settings.profile,
        "t_f": data.horizon, "k_e": settings.eval.k_e,
        "windows": {split: len(arrays) for split, arrays in data.splits.items()},
        **ynet, "train": trained[YNET],
        "semantic": trained["semantic"],
        "baselines": scores,
        "seconds": trained["seconds"] + time.perf_counter() - start,
    }
    return record, predictions
