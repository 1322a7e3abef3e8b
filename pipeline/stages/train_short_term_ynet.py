"""Stage `train_short_term_ynet@<dataset>`: Y-net trained on one short-term benchmark (paper Tables 1-2).

`ynet.<profile>` with the short-term goal-only waypoint and the benchmark's map scale, epochs and
training departures (`ynet_training.<benchmark>`) from `short_term_models.<profile>`
(`pipeline.runners.short_term.ynet_settings`); the epoch is selected on a seeded sample of
`val_windows` validation windows. Writes the checkpoint folder (resumable; SIGTERM / SIGINT or
`runtime.max_minutes` checkpoint mid-epoch and exit 143 / 130 / 75) and the training record; a
dataset outside `ynet_datasets` gets the not-run record (and no checkpoint folder, as before the
split). Params: `profile`, `runtime.device`, `runtime.max_minutes`, `short_term.n_past`,
`short_term.n_future`, `ynet.<profile>`, `short_term_models.<profile>`: `epochs.ynet`,
`ynet_steps_per_epoch`, `ynet_training.<benchmark>`, `val_windows`, `ynet_sdd` / `ynet_ethucy`,
`ynet_datasets`, `why_subset`, `seed`.

    python -m pipeline.stages.train_short_term_ynet --dataset eth --windows data/short_term \
        --maps data/short_term/ethucy_semantic --sdd data/raw/sdd \
        --checkpoint-dir checkpoints/short_term/eth_ynet --metrics metrics/short_term/train/eth_ynet.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.registry import SHORT_TERM, short_term
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.ynet import YnetSettings
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.model_list import YNET
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.short_term import (missing_raw_source, not_run_record, train_ynet,
                                         training_record, ynet_maps)

MODEL = YNET


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--maps", type=Path, required=True,
                        help="Y-net's scene maps: data/semantic_maps (sdd) or <windows>/ethucy_semantic")
    parser.add_argument("--sdd", type=Path, help="fetched SDD root (sdd: scene sizes)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="training record (JSON)")
    args = parser.parse_args(argv)
    params = read_params()
    profile = active_profile(params)
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    if args.dataset not in settings.ynet_datasets:
        write_json(not_run_record(args.dataset, MODEL, profile, settings), args.metrics)
        print(f"train_short_term_ynet: Y-net not run on {args.dataset} in the {profile} profile")
        return
    benchmark = short_term(args.dataset)
    missing = missing_raw_source(benchmark, vars(args), images=False)
    if missing:
        parser.error(missing)
    windows = load_section(ShortTermParams, "short_term", params)
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device, purpose=TRAINING)

    bench = benchmark.load(args.windows, windows.n_past, windows.n_future)
    scene_ids = set(bench.train.scene_id) | set(bench.val.scene_id) | set(bench.test.scene_id)
    maps, classes = ynet_maps(args.maps)
    sizes = benchmark.scene_sizes(args.windows, args.sdd, scene_ids)
    model_settings = benchmark.ynet_settings(load_profile(YnetSettings, "ynet", params), settings,
                                             windows.n_future, classes)
    with Preemption(runtime.max_minutes) as preemption:
        facts = train_ynet(bench, maps, sizes, model_settings, windows.n_past, args.checkpoint_dir,
                           settings.val_windows, settings.seed, device, preemption)
    print(f"train_short_term_ynet: trained on {describe(device)}")  # after: training sets threads
    write_json(training_record(args.dataset, MODEL, profile, facts), args.metrics)


if __name__ == "__main__":
    main()
