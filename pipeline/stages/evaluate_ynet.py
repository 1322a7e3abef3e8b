"""Stage `evaluate_ynet`: Y-net on the test windows with TTST and CWS, over several seeded rounds.

Separate from training, so `dvc exp run -S ttst.temperature=...` re-runs only this and the report.
Writes ADE / FDE in original pixels as mean and spread over `eval.<profile>.rounds` rounds, the
Table 3 ablation and the K_e x K_a grid (`pipeline.runners.ynet_scoring.evaluation_sequence`),
every round of the main setting's test predictions (paths and sampled goals in original pixels,
`pipeline.harness.predictions`; in `release_tf30/`, as the window ids are the release table's),
and three windows' heatmaps for the qualitative figure. The model's settings come from its
checkpoint. Params: `eval.<profile>`, `ttst`, `cws`, `profile`, `runtime.device` (and
`windows.n_past`, passed as --n-past).

    python -m pipeline.stages.evaluate_ynet --windows data/windows/release_tf30.parquet \
        --model data/ynet/model.pt --semantic-maps data/semantic_maps --sdd data/raw/sdd \
        --n-past 5 --metrics metrics/ynet_eval.json --qualitative data/ynet_predictions/qualitative.npz \
        --predictions data/predictions/long_term/release_tf30/ynet.parquet
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.ttst import TtstParams
from pipeline.data.labels import image_sizes
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.data.window_table import to_arrays
from pipeline.device import SCORING, describe, select_device
from pipeline.harness.predictions import PredictionRounds
from pipeline.io import exit_on_bad_intermediate, write_json, write_npz
from pipeline.runners.ynet_scoring import (evaluation_sequence, load_for_scoring,
                                           prediction_metadata, qualitative_arrays,
                                           sampling_options)


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=Path, required=True)
    parser.add_argument("--model", type=Path, required=True)
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True)
    parser.add_argument("--n-past", type=int, default=5)
    parser.add_argument("--metrics", type=Path, required=True)
    parser.add_argument("--qualitative", type=Path, help="npz for the report's qualitative figure")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round of the main setting's test predictions (parquet)")
    parser.add_argument("--main-only", action="store_true", help="skip the ablation and K_a grid")
    args = parser.parse_args(argv)
    params = read_params()
    ttst = load_section(TtstParams, "ttst", params)
    cws = load_section(CwsParams, "cws", params)
    eval_params = load_profile(EvalParams, "eval", params)
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=SCORING)

    print(f"evaluate_ynet: on {describe(device)}")
    table = pd.read_parquet(args.windows)
    test = to_arrays(table[table["split"] == "test"], args.n_past)
    semantic_maps = load_semantic_maps(args.semantic_maps)
    model, settings, scenes = load_for_scoring(args.model, test, semantic_maps,
                                               image_sizes(args.sdd, set(test.scene_id)),
                                               eval_params.threads, device)

    def after_main(result: dict) -> None:
        result["seconds_per_window"] = result["main_seconds"] / (len(test) * eval_params.rounds)
        print(f"evaluate_ynet: ADE {result['main']['ade']['mean']:.2f} ± {result['main']['ade']['std']:.2f}"
              f"  FDE {result['main']['fde']['mean']:.2f} ± {result['main']['fde']['std']:.2f}"
              f"  ({result['main_seconds']:.0f} s)")

    kept = PredictionRounds(test.window_id)
    scores = evaluation_sequence(model, scenes, settings, eval_params, ttst, cws, test.future,
                                 extras=not args.main_only, after_main=after_main, kept=kept)
    main_options = sampling_options(eval_params.k_e, eval_params.k_a, ttst, cws, True, True)
    kept.write(args.predictions, prediction_metadata(args.windows, main_options, args.model))
    write_json({"profile": active_profile(params), "t_f": int(test.future.shape[1]),
                "n_windows": len(test), "rounds": eval_params.rounds, **scores}, args.metrics)
    if args.qualitative:
        write_npz(args.qualitative, qualitative_arrays(model, scenes, settings, eval_params, ttst,
                                                       cws, args.sdd))


if __name__ == "__main__":
    main()
