"""Stage `ynet_horizon`: Y-net trained and scored at one prediction horizon (paper Figure 4).

The t_f = 30 s point is the main Y-net (`train_ynet` / `evaluate_ynet` on the release windows,
which equal `data/horizon_windows/tf30.parquet`); this stage covers the other horizons on the
horizon tables. Waypoints are scaled with the horizon as `train_ynet` does. Which horizons are
trained, for how many epochs, and how many evaluation rounds come from `ynet_horizons.<profile>`:
a horizon outside that list still gets a metrics file saying why it was not run, so the report
explains the gap instead of leaving it blank. Training resumes from `<checkpoint-dir>/last.pt`.

    python -m pipeline.ynet_horizon --horizon 10 --table data/horizon_windows/tf10.parquet \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd \
        --checkpoint-dir checkpoints/ynet_tf10 --metrics metrics/ynet_horizons/tf10.json
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import pandas as pd
import torch

from pipeline.device import RuntimeParams, describe, select_device
from pipeline.evaluate_ynet import (CwsParams, EvalParams, TtstParams, evaluate, load_model,
                                    sampling_options, write_json)
from pipeline.params import load_profile, load_section, read_params
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.semantic_maps import load_semantic_maps
from pipeline.train_ynet import YnetSettings, image_sizes, scale_waypoints, train
from pipeline.window_table import to_arrays
from pipeline.windows import WindowParams
from pipeline.ynet_data import group_by_scene


@dataclass(frozen=True)
class HorizonParams:
    """Section `ynet_horizons.<profile>` of params.yaml."""

    epochs: dict[int, int] = field(default_factory=dict)
    """Horizon (s) -> training epochs, for the horizons this profile trains Y-net at (the other
    settings are `ynet.<profile>`'s); any other horizon gets a 'not run' record."""
    rounds: int = 3
    """Evaluation rounds (TTST + CWS, K_e from `eval.<profile>`, K_a = 1)."""
    why_subset: str = ""
    """Shown in the report for a horizon this profile does not train."""

    def __post_init__(self):
        if self.rounds < 1 or any(int(e) < 1 for e in self.epochs.values()):
            raise ValueError("epochs and rounds must be >= 1")

    @property
    def horizons(self) -> list[int]:
        return sorted(int(h) for h in self.epochs)


def not_run_record(horizon: int, profile: str, params: HorizonParams) -> dict:
    reason = (f"Y-net is not trained at t_f = {horizon} s in the {profile} profile "
              f"(it trains {', '.join(map(str, params.horizons)) or 'no horizon'} s here)")
    if params.why_subset:
        reason += f": {params.why_subset}"
    return {"t_f": horizon, "profile": profile, "trained": False, "not_run_reason": reason}


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="horizon window table (parquet)")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True)
    args = parser.parse_args(argv)
    params = read_params()
    profile = params["profile"]
    horizon_params = load_profile(HorizonParams, "ynet_horizons", params)
    args.checkpoint_dir.mkdir(parents=True, exist_ok=True)
    if args.horizon not in horizon_params.horizons:
        write_json(not_run_record(args.horizon, profile, horizon_params), args.metrics)
        print(f"ynet_horizon: t_f = {args.horizon} s not trained in the {profile} profile")
        return

    settings = load_profile(YnetSettings, "ynet", params)
    eval_params = load_profile(EvalParams, "eval", params)
    ttst, cws = load_section(TtstParams, "ttst", params), load_section(CwsParams, "cws", params)
    n_past = load_section(WindowParams, "windows", params).n_past
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device)

    table = pd.read_parquet(args.table)
    train_arrays, val_arrays, test_arrays = (to_arrays(table[table["split"] == split], n_past)
                                             for split in ("train", "val", "test"))
    n_future = train_arrays.future.shape[1]
    if n_future != args.horizon:  # 1 FPS: one step per second
        raise ValueError(f"{args.table}: windows predict {n_future} steps, not t_f = {args.horizon}")
    epochs = {int(h): int(e) for h, e in horizon_params.epochs.items()}[args.horizon]
    settings = replace(settings, epochs=epochs,
                       waypoints=scale_waypoints(settings.waypoints, n_future))
    semantic_maps = load_semantic_maps(args.semantic_maps)
    scene_ids = set(train_arrays.scene_id) | set(val_arrays.scene_id) | set(test_arrays.scene_id)
    sizes = image_sizes(args.sdd, scene_ids)
    best = args.checkpoint_dir / "best.pt"
    with Preemption(runtime.max_minutes) as preemption:
        summary = train(train_arrays, val_arrays, semantic_maps, sizes, settings, n_past,
                        args.checkpoint_dir / "last.pt", best, args.checkpoint_dir / "history.csv",
                        device=device, preemption=preemption)

    model, settings = load_model(best, device)
    print(f"ynet_horizon: scoring on {describe(device)}")
    torch.set_num_threads(settings.threads)
    scenes = group_by_scene(test_arrays, semantic_maps, sizes, settings.resize, device)
    options = sampling_options(eval_params.k_e, 1, ttst, cws, True, True)
    start = time.perf_counter()
    scores = evaluate(model, scenes, settings, options, eval_params, test_arrays.future,
                      horizon_params.rounds, f"t_f={args.horizon}")
    result = {"t_f": args.horizon, "profile": profile, "trained": True, "n_windows": len(test_arrays),
              "rounds": horizon_params.rounds, "waypoints": settings.waypoints, "main": scores,
              "eval_seconds": time.perf_counter() - start, **summary}
    write_json(result, args.metrics)
    print(f"ynet_horizon t_f = {args.horizon}: ADE {scores['ade']['mean']:.2f}  "
          f"FDE {scores['fde']['mean']:.2f} over {len(test_arrays)} test windows")


if __name__ == "__main__":
    main()
