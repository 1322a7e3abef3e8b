"""Stage `evaluate_ind`: the inD benchmark scored (paper Tables 3/4).

Y-net (its settings from the checkpoint) with TTST + CWS on the test windows over `eval.rounds`
rounds, the Table 4 ablation and the K_e x K_a grid; S-GAN, PECNet, R-PECNet and constant velocity
as `evaluate_baseline` scores them (`pipeline.runners.long_term_benchmark` on
`pipeline.benchmarks.ind.IND`). Writes `metrics/ind_benchmark.json` in
the layout of `metrics/ynet_eval.json` plus "baselines", "semantic" and the training facts, and every
round of each model's test predictions into the folder `--predictions` (`<model>.parquet`, pixels,
`pipeline.harness.predictions`); inD not provided: the not-provided record and empty predictions
files that give its reason, at once. Params: `profile`, `runtime.device`, `eval.<profile>`,
`ttst`, `cws`, `evaluate_baseline`, `train_baseline.threads`.

    python -m pipeline.stages.evaluate_ind --ind data/ind --checkpoint-dir checkpoints/ind \
        --train-metrics metrics/ind_train.json --metrics metrics/ind_benchmark.json \
        --predictions data/predictions/ind
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pipeline.benchmarks.ind import IND
from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.ttst import TtstParams
from pipeline.device import SCORING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.runners.long_term_benchmark import EvalSettings, evaluate_benchmark, write_predictions


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ind", type=Path, required=True, help="output folder of stage ind_windows")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="of stage train_ind")
    parser.add_argument("--train-metrics", type=Path, required=True, help="of stage train_ind")
    parser.add_argument("--metrics", type=Path, required=True)
    parser.add_argument("--predictions", type=Path, required=True,
                        help="folder of every model's stored test predictions (<model>.parquet)")
    args = parser.parse_args(argv)
    params = read_params()
    settings = EvalSettings(
        profile=active_profile(params),
        eval=load_profile(EvalParams, "eval", params),
        ttst=load_section(TtstParams, "ttst", params),
        cws=load_section(CwsParams, "cws", params),
        evaluate_baseline=load_section(EvaluateBaselineParams, "evaluate_baseline", params),
        threads=load_section(TrainBaselineParams, "train_baseline", params).threads,
        runtime=load_section(RuntimeParams, "runtime", params))
    device = select_device(settings.runtime.device, purpose=SCORING)
    print(f"evaluate_ind: on {describe(device)}")
    trained = json.loads(args.train_metrics.read_text())
    result, predictions = evaluate_benchmark(IND, args.ind, args.checkpoint_dir, trained, settings,
                                             device)
    write_predictions(IND, args.predictions, predictions,
                      None if result["provided"] else result["reason"])
    write_json(result, args.metrics, sort_keys=True)
    if not result["provided"]:
        print(f"evaluate_ind: inD not provided: {result['reason']}")
        return
    main_result = result["main"]
    print(f"evaluate_ind: Y-net ADE {main_result['ade']['mean']:.2f}  FDE {main_result['fde']['mean']:.2f}; "
          + "  ".join(f"{m} ADE {r['ade']['mean']:.2f}" for m, r in result["baselines"].items()))


if __name__ == "__main__":
    main()
