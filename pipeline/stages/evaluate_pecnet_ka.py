"""Stage `evaluate_pecnet_ka`: PECNet's side of the paper's K_a figure.

The paper gives PECNet 20 x K_a samples per window for each K_a of Y-net's K_e = 20 curve. The K_a
values are those of Y-net's own grid (`eval.<profile>.ka_grid_k_a`), so the two curves share their
x values; K is `evaluate_baseline.k` x K_a, scored with the shared metric over
`evaluate_baseline.rounds` rounds (`pipeline.runners.baseline_runs.ka_rows`). Params:
`evaluate_baseline`, `eval.<profile>.ka_grid_k_a`, `profile`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_pecnet_ka --table data/horizon_windows/tf30.parquet \
        --checkpoint-dir checkpoints/pecnet_tf30 --metrics metrics/baselines/pecnet_ka.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from pipeline.config.eval import EvalParams
from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.data.window_table import load_windows
from pipeline.device import SCORING, describe, select_device
from pipeline.runners import baselines
from pipeline.runners.baseline_runs import ka_rows
from pipeline.harness.model_runs import split_to_score
from pipeline.io import write_json
from pipeline.model_list import PECNET


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, required=True, help="t_f = 30 window table (parquet)")
    parser.add_argument("--horizon", type=int, default=30, help="t_f in seconds")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="PECNet trained at --horizon")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON list written")
    args = parser.parse_args(argv)
    all_params = read_params()
    params = load_section(EvaluateBaselineParams, "evaluate_baseline", all_params)
    k_as = sorted(set(load_profile(EvalParams, "eval", all_params).ka_grid_k_a))
    n_past = load_section(WindowParams, "windows", all_params).n_past
    runtime = load_section(RuntimeParams, "runtime", all_params)
    torch.set_num_threads(params.threads)
    device = select_device(runtime.device, purpose=SCORING)
    print(f"evaluate_pecnet_ka: {describe(device)}", flush=True)

    pecnet = baselines.Baseline(PECNET, device=device, selection=params.epoch_selection)
    test, truth = split_to_score(load_windows(args.table, n_past, args.horizon), params.split)
    if len(test) == 0:
        raise ValueError(f"{args.table}: no {params.split} windows")
    rows = ka_rows(pecnet, test, truth, args.checkpoint_dir, k_as, params.k, params.rounds,
                   params.seed)
    for row in rows:
        print(f"PECNet K_a = {row['k_a']} (K = {row['k']}): ADE {row['ade']['mean']:.2f}  FDE {row['fde']['mean']:.2f}")
    write_json(rows, args.metrics)


if __name__ == "__main__":
    main()
