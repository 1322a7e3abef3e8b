"""Which roll-out gives the paper's R-PECNet? A labelled diagnostic (stage `rpecnet_rollouts`).

The paper's R-PECNet at t_f = 30 s has FDE / ADE = 2.9, the signature of an error that compounds;
ours (`rpecnet.INDEPENDENT`: K independent chains, fresh z every round, re-centred every round)
has about 2. This rolls the same t_f = 5 PECNet out in the ways a careless implementation could
have (`rpecnet.VARIANTS`), scores each on the choice split (validation: best of K, independent
minima of ADE and FDE per window, as the headline), chooses the variant whose FDE / ADE is the
nearest to the paper's, and scores only that one on the test windows. Nothing is chosen on test;
none of these numbers replaces the headline R-PECNet.

Record (`rpecnet_rollouts`):
    {"model": "rpecnet", "checkpoint_dir", "epoch_selection", "device", "k", "seed",
     "split_for_choice", "target_fde_over_ade", "variants": [...],
     "horizons": {"tf<H>": {"t_f", "choice": {"split", "n_windows", "variants": {name: scores}},
                            "chosen", "distance_to_target", "test": {"variant", "n_windows",
                            **scores}}},
     "wall_seconds"}
with scores {"ade", "fde", "fde_over_ade", "seconds"} in original pixels.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from pipeline.data.window_table import WindowArrays, load_windows
from pipeline.device import SCORING, describe, select_device
from pipeline.device import generator as seeded_generator
from pipeline.data.window_table import select_split
from pipeline.model_list import RPECNET
from pipeline.runners.baselines.rpecnet import VARIANTS, RecurrentPecnet
from pipeline.harness.scoring import min_ade_fde

if TYPE_CHECKING:  # annotations only: a stage's code holds the sections it reads (code_graph)
    from pipeline.config.rpecnet_rollouts import RpecnetRolloutsParams
    from pipeline.config.runtime import RuntimeParams

MODEL = RPECNET


def check_variants(names: Sequence[str]) -> list[str]:
    """`names` as a list, or a ValueError naming those the roll-out does not know."""
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        raise ValueError(f"rpecnet_rollouts.variants: unknown roll-out(s) {unknown}; known: "
                         f"{list(VARIANTS)}")
    return list(names)


def best_of_k_scores(pred: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Mean over windows of the best-of-K ADE and FDE (independent minima per window: the
    headline protocol) of pred (N, K, T, 2) against truth (N, T, 2), and their ratio FDE / ADE
    (the ratio of the means, as the paper's table gives them)."""
    errors = min_ade_fde(pred, truth)
    ade, fde = float(errors["ade"].mean()), float(errors["fde"].mean())
    return {"ade": ade, "fde": fde, "fde_over_ade": fde / ade if ade > 0 else float("nan")}


def choose_variant(scores: Mapping[str, Mapping[str, float]], target: float
                   ) -> tuple[str, float]:
    """(name, |ratio - target|) of the variant of `scores` {name: {"fde_over_ade", ...}} whose
    FDE / ADE is the nearest to `target`; ties go to the first listed. NaN ratios never win."""
    distances = {name: abs(s["fde_over_ade"] - target) for name, s in scores.items()
                 if np.isfinite(s["fde_over_ade"])}
    if not distances:
        raise ValueError(f"no variant with a finite FDE / ADE to choose from: {list(scores)}")
    name = min(distances, key=lambda n: distances[n])  # the first of equal distances
    return name, distances[name]


def score_variant(model: RecurrentPecnet, arrays: WindowArrays, variant: str, k: int, seed: int,
                  device: torch.device) -> dict[str, float]:
    """`best_of_k_scores` of one roll-out `variant` of `model` on `arrays`, K samples from a
    fresh generator seeded `seed` (every variant the same), with the seconds it took."""
    start = time.perf_counter()
    pred = model.predict(arrays, k, seeded_generator(device, seed), variant=variant)
    return {**best_of_k_scores(pred, arrays.future), "seconds": time.perf_counter() - start}


def horizon_record(model: RecurrentPecnet, arrays: WindowArrays, t_f: int,
                   params: RpecnetRolloutsParams, device: torch.device, source: Path
                   ) -> dict[str, Any]:
    """Every variant on the choice split of `arrays` (one horizon table, every split), the
    choice, and the chosen variant alone on its test split."""
    choice_set = select_split(arrays, params.split_for_choice)
    test_set = select_split(arrays, "test")
    for name, subset in ((params.split_for_choice, choice_set), ("test", test_set)):
        if len(subset) == 0:
            raise ValueError(f"{source}: no {name} windows")
    scores = {}
    for variant in params.variants:
        scores[variant] = score_variant(model, choice_set, variant, params.k, params.seed, device)
        s = scores[variant]
        print(f"tf{t_f} {params.split_for_choice} {variant}: ADE {s['ade']:.2f} FDE {s['fde']:.2f}"
              f" FDE/ADE {s['fde_over_ade']:.3f} ({s['seconds']:.0f} s)", flush=True)
    chosen, distance = choose_variant(scores, params.target_fde_over_ade)
    test = score_variant(model, test_set, chosen, params.k, params.seed, device)
    print(f"tf{t_f} chosen {chosen}; test ADE {test['ade']:.2f} FDE {test['fde']:.2f}", flush=True)
    return {"t_f": t_f,
            "choice": {"split": params.split_for_choice, "n_windows": len(choice_set),
                       "variants": scores},
            "chosen": chosen, "distance_to_target": distance,
            "test": {"variant": chosen, "n_windows": len(test_set), **test}}


def rollouts_record(horizon_windows: Path, checkpoint_dir: Path, settings: RpecnetRolloutsParams,
                    selection: str, n_past: int, runtime: RuntimeParams) -> dict[str, Any]:
    """What the stage does: for every t_f of `rpecnet_rollouts.horizons`, `horizon_record` on
    `<horizon_windows>/tf<t_f>.parquet` with the PECNet of `checkpoint_dir` (the t_f = 5 one, the
    epoch `selection` keeps: `evaluate_baseline.epoch_selection`, as the headline R-PECNet), under
    `settings` (section `rpecnet_rollouts`), `n_past` (`windows.n_past`) and `runtime.device`."""
    check_variants(settings.variants)
    torch.set_num_threads(settings.threads)
    device = select_device(runtime.device, purpose=SCORING)
    print(f"rpecnet_rollouts: {describe(device)}", flush=True)
    start = time.perf_counter()
    model = RecurrentPecnet.load(checkpoint_dir, device, selection)
    horizons = {}
    for t_f in settings.horizons:
        table = Path(horizon_windows) / f"tf{t_f}.parquet"
        horizons[f"tf{t_f}"] = horizon_record(model, load_windows(table, n_past, t_f), t_f,
                                              settings, device, table)
    return {"model": MODEL, "checkpoint_dir": Path(checkpoint_dir).as_posix(),
            "epoch_selection": selection, "device": describe(device), "k": settings.k,
            "seed": settings.seed, "split_for_choice": settings.split_for_choice,
            "target_fde_over_ade": settings.target_fde_over_ade,
            "variants": list(settings.variants), "horizons": horizons,
            "wall_seconds": time.perf_counter() - start}
