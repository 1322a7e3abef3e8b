"""Stage `evaluate_short_term_ynet@<dataset>`: Y-net scored on one short-term benchmark (paper
Tables 1-2).

Loads the best epoch of `train_short_term_ynet` (its settings from the checkpoint) and scores it on
every test window at each K_e of `k_sdd` / `k_ethucy`: TTST (the short-term `temperature`, the
benchmark's `rel_threshold`), no CWS, K_a = 1, over `rounds` seeded rounds; ETH/UCY errors in metres
(`pipeline.runners.short_term`). Also writes every round of the first K_e's test predictions (paths
and sampled goals in the benchmark's unit, window ids of the dataset's table in `--windows`;
`pipeline.harness.predictions`) and a few test windows' heatmaps and samples in the layout of the
long-term qualitative file (`--qualitative`; pixels of the scene image resized to the model's map:
SDD's reference.jpg, ETH/UCY's camera image on the oracle grid the homography maps to metres). A
dataset that was not trained gets the training stage's not-run record, an empty predictions file
and a qualitative file holding only `not_run_reason`, all giving the same reason. Params:
`profile`, `runtime.device`, `short_term.n_past`, `short_term.n_future`,
`short_term_models.<profile>`: `temperature`, `rel_threshold.<benchmark>`, `k_sdd` / `k_ethucy`, `rounds`,
`seed`, `eval_batch_size`, `eval_chunk_size`, `eval_threads`, `bf16`.

    python -m pipeline.stages.evaluate_short_term_ynet --dataset eth --windows data/short_term \
        --maps data/short_term/ethucy_semantic --sdd data/raw/sdd \
        --ethucy-scenes data/raw/ethucy-scenes --checkpoint-dir checkpoints/short_term/eth_ynet \
        --train-metrics metrics/short_term/train/eth_ynet.json --metrics metrics/short_term/runs/eth_ynet.json \
        --predictions data/predictions/short_term/eth/ynet.parquet \
        --qualitative data/predictions/short_term/eth/ynet_qualitative.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from pipeline.benchmarks.registry import SHORT_TERM, short_term
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.device import SCORING, describe, select_device
from pipeline.harness.predictions import PredictionRounds, write_no_predictions
from pipeline.io import exit_on_bad_intermediate, write_json, write_npz
from pipeline.model_list import YNET
from pipeline.runners.short_term import (missing_raw_source, run_record, score_ynet, ynet_maps,
                                         ynet_options, ynet_qualitative)
from pipeline.runners.ynet_scoring import load_for_scoring

MODEL = YNET


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--maps", type=Path, required=True,
                        help="Y-net's scene maps: data/semantic_maps (sdd) or <windows>/ethucy_semantic")
    parser.add_argument("--sdd", type=Path, help="fetched SDD root (sdd: scene sizes and images)")
    parser.add_argument("--ethucy-scenes", type=Path,
                        help="fetched ETH/UCY camera images (ETH/UCY: the qualitative scene images)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="of train_short_term_ynet")
    parser.add_argument("--train-metrics", type=Path, required=True, help="of train_short_term_ynet")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round of the first K_e's test predictions (parquet)")
    parser.add_argument("--qualitative", type=Path, required=True,
                        help="a few test windows' heatmaps and samples (npz)")
    args = parser.parse_args(argv)
    benchmark = short_term(args.dataset)
    trained = json.loads(args.train_metrics.read_text())
    if not trained["trained"]:
        reason = trained["not_run_reason"]
        write_no_predictions(args.predictions, benchmark.prediction_metadata(args.windows, MODEL),
                             reason)
        write_npz(args.qualitative, {"not_run_reason": np.array(reason)})
        write_json(trained, args.metrics)
        print(f"evaluate_short_term_ynet: Y-net not run on {args.dataset}: {reason}")
        return
    missing = missing_raw_source(benchmark, vars(args), images=True)
    if missing:
        parser.error(missing)
    params = read_params()
    profile = active_profile(params)
    settings = load_profile(ShortTermModelsParams, "short_term_models", params)
    windows = load_section(ShortTermParams, "short_term", params)
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=SCORING)

    bench = benchmark.load(args.windows, windows.n_past, windows.n_future)
    maps, _ = ynet_maps(args.maps)
    sizes = benchmark.scene_sizes(args.windows, args.sdd, set(bench.test.scene_id))
    image_of = benchmark.scene_images(args.windows, args.sdd, args.ethucy_scenes)
    checkpoint = args.checkpoint_dir / "best.pt"
    model, loaded, scenes = load_for_scoring(checkpoint, bench.test, maps, sizes,
                                             settings.eval_threads, device)
    print(f"evaluate_short_term_ynet: on {describe(device)}")  # after: loading sets the threads
    ks = benchmark.ks(settings)
    kept = PredictionRounds(bench.test.window_id)
    results, seconds, reported = score_ynet(model, loaded, scenes, bench, benchmark, settings, ks,
                                            kept)
    qualitative = ynet_qualitative(model, loaded, scenes, bench, benchmark, settings, ks[0],
                                   image_of)
    options = ynet_options(settings, benchmark, ks[0])
    kept.write(args.predictions, benchmark.prediction_metadata(
        args.windows, MODEL, ks, k_e=options.K_e, k_a=options.K_a,
        sampling=dataclasses.asdict(options), checkpoint=str(checkpoint)))
    write_npz(args.qualitative, qualitative)
    facts = {**trained["train"], "eval_seconds": seconds, "settings": reported}
    write_json(run_record(args.dataset, MODEL, profile, bench, settings.rounds, ks, results, facts),
               args.metrics)
    main_k = results[ks[0]]
    print(f"evaluate_short_term_ynet {args.dataset}: K = {ks[0]} ADE {main_k['ade']['mean']:.3f} "
          f"FDE {main_k['fde']['mean']:.3f} {bench.unit} over {len(bench.test)} test windows")


if __name__ == "__main__":
    main()
