"""Stage `evaluate_short_term_ynet@<dataset>`: Y-net scored on one short-term benchmark (paper
Tables 1-2).

Loads the best epoch of `train_short_term_ynet` (its settings from the checkpoint) and scores it on
every test window at each K_e of `k_sdd` / `k_ethucy`: TTST (the short-term `temperature`,
`rel_threshold`), no CWS, K_a = 1, over `rounds` seeded rounds; ETH/UCY errors in metres
(`pipeline.runners.short_term`). A dataset that was not trained gets the training stage's not-run
record. Params: `profile`, `runtime.device`, `short_term.n_past`, `short_term.n_future`,
`short_term_models.<profile>`: `temperature`, `rel_threshold`, `k_sdd` / `k_ethucy`, `rounds`,
`seed`, `eval_batch_size`, `eval_chunk_size`, `bf16`.

    python -m pipeline.stages.evaluate_short_term_ynet --dataset eth --windows data/short_term \
        --maps data/short_term/ethucy_semantic --sdd data/raw/sdd \
        --checkpoint-dir checkpoints/short_term/eth_ynet \
        --train-metrics metrics/short_term/train/eth_ynet.json --metrics metrics/short_term/runs/eth_ynet.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pipeline.config import (DATASETS, RuntimeParams, ShortTermModelsParams, ShortTermParams,
                             load_profile, load_section, read_params)
from pipeline.device import describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.runners.short_term import load_dataset, run_record, score_ynet, ynet_inputs

MODEL = "ynet"


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=DATASETS)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--maps", type=Path, required=True,
                        help="Y-net's scene maps: data/semantic_maps (sdd) or <windows>/ethucy_semantic")
    parser.add_argument("--sdd", type=Path, help="fetched SDD root (sdd: scene sizes)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="of train_short_term_ynet")
    parser.add_argument("--train-metrics", type=Path, required=True, help="of train_short_term_ynet")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    args = parser.parse_args(argv)
    trained = json.loads(args.train_metrics.read_text())
    if not trained["trained"]:
        write_json(trained, args.metrics)
        print(f"evaluate_short_term_ynet: Y-net not run on {args.dataset}: {trained['not_run_reason']}")
        return
    if args.dataset == "sdd" and args.sdd is None:
        parser.error("Y-net on sdd needs --sdd")
    params = read_params()
    profile = params["profile"]
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    device = select_device(load_section(RuntimeParams, "runtime", params).device)
    print(f"evaluate_short_term_ynet: on {describe(device)}")

    bench, ethucy_scenes = load_dataset(args.windows, args.dataset, windows.n_past, windows.n_future)
    maps, sizes, _ = ynet_inputs(args.maps, args.sdd, set(bench.test.scene_id), ethucy_scenes)
    ks = settings.ks(args.dataset)
    results, seconds, reported = score_ynet(bench, maps, sizes, args.checkpoint_dir, settings, ks,
                                            device)
    facts = {**trained["train"], "eval_seconds": seconds, "settings": reported}
    write_json(run_record(args.dataset, MODEL, profile, bench, settings.rounds, ks, results, facts),
               args.metrics)
    main_k = results[ks[0]]
    print(f"evaluate_short_term_ynet {args.dataset}: K = {ks[0]} ADE {main_k['ade']['mean']:.3f} "
          f"FDE {main_k['fde']['mean']:.3f} {bench.unit} over {len(bench.test)} test windows")


if __name__ == "__main__":
    main()
